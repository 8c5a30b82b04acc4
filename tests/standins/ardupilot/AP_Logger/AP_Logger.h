// stand-in: ArduPilot AP_Logger/AP_Logger.h (the calls used)
#pragma once
#include <AP_Logger/LogStructure.h>

class AP_Logger {
public:
    void WriteBlock(const void *pBuffer, uint16_t size);
};

namespace AP {
AP_Logger &logger();
};
