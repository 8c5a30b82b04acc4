// stand-in: ArduPilot AP_HAL/AP_HAL.h (system clock)
#pragma once
#include <stdint.h>

namespace AP_HAL {
uint64_t micros64();
};
