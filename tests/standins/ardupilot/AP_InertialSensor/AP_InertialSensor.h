// stand-in: ArduPilot AP_InertialSensor/AP_InertialSensor.h (the calls used)
#pragma once
#include <AP_Math/AP_Math.h>

class AP_InertialSensor {
public:
    const Vector3f &get_accel() const;
};

namespace AP {
AP_InertialSensor &ins();
};
