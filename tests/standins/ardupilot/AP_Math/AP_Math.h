// stand-in: ArduPilot AP_Math/AP_Math.h (Vector3f, Quaternion, GRAVITY_MSS)
#pragma once
#include <math.h>
#include <stdint.h>

#define GRAVITY_MSS 9.80665f

class Vector3f {
public:
    float x, y, z;
    Vector3f() : x(0.0f), y(0.0f), z(0.0f) {}
    Vector3f(float x0, float y0, float z0) : x(x0), y(y0), z(z0) {}
};

class Quaternion {
public:
    float q1, q2, q3, q4;  // w, x, y, z
    Quaternion() : q1(1.0f), q2(0.0f), q3(0.0f), q4(0.0f) {}
};
