// stand-in: ArduPilot AP_ESC_Telem/AP_ESC_Telem.h (the calls used)
#pragma once
#include <stdint.h>

class AP_ESC_Telem {
public:
    bool get_rpm(uint8_t esc_index, float &rpm) const;
};

namespace AP {
AP_ESC_Telem &esc_telem();
};
