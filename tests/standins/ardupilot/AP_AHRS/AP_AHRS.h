// stand-in: ArduPilot AP_AHRS/AP_AHRS.h (the calls used)
#pragma once
#include <AP_Math/AP_Math.h>

class AP_AHRS {
public:
    bool get_quaternion(Quaternion &quat) const __attribute__((warn_unused_result));
    bool get_velocity_NED(Vector3f &vec) const __attribute__((warn_unused_result));
    const Vector3f &get_accel_ef() const;
    bool get_likely_flying(void) const;
};

namespace AP {
AP_AHRS &ahrs();
};
