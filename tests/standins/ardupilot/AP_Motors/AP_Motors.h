// stand-in: ArduPilot AP_Motors/AP_Motors.h (the calls used)
#pragma once

class AP_Motors {
public:
    virtual ~AP_Motors() {}
    float get_throttle() const;
    virtual float get_throttle_hover() const = 0;
};

namespace AP {
AP_Motors *motors();
};
