// Calling the generated estimator from C++ (C++11 or later): the m300's hover in still air, at 100 Hz.
// Build:  cc -c -O2 m300_wind.c && c++ -std=c++11 -I. example.cpp m300_wind.o -lm
// (tests/test_docs.py compiles and runs this file against generated_c/m300/).
#include <cmath>
#include <cstdio>

#include "m300_wind.h"  // extern "C" inside: the C symbols link from C++ as they are

int main() {
    m300_wind_state_t state;
    m300_wind_init(&state);

    // Hover: each of the 4 rotors carries a quarter of the weight. Solve the airframe's thrust curve
    // 207 w^2 + 11.34 w + 0.01315 = m g / 4 for w = rpm / 12000.
    const double per_rotor_n = 8.0 * 9.80665 / 4.0;
    const double w = (-11.34 + std::sqrt(11.34 * 11.34 - 4.0 * 207.0 * (0.01315 - per_rotor_n))) / (2.0 * 207.0);
    const float rpm = static_cast<float>(w * 12000.0);

    // C++ before C++20 has no designated initializers: value-initialise (every field 0), then assign.
    m300_wind_input_t in = m300_wind_input_t();
    in.q[0] = 1.0f;  // level, facing north: w, x, y, z = 1, 0, 0, 0
    for (int i = 0; i < 4; ++i) in.rotor_rpm[i] = rpm;
    in.yaw_ref = 0.0f;

    m300_wind_output_t out = m300_wind_output_t();
    int status = 0;
    const float period_s = 0.01f;
    for (int k = 0; k < 1000; ++k) {  // 10 s
        // The first call has no previous sample: pass the nominal period (any dt in [1e-5 s, max_dt]
        // is accepted; the first accepted sample only initialises the filters).
        in.dt = period_s;
        status = m300_wind_step(&state, &in, &out);
        if (status & M300_WIND_REJECTED_MASK) {
            std::printf("sample %d rejected: status 0x%02x\n", k, status);
            return 1;
        }
        if (k == 0) std::printf("first sample: status 0x%02x (SETTLING is 0x40)\n", status);
    }
    std::printf("after 10 s: status %d, wind %.4f m/s horizontal, %.4f m/s up, force %.4f %.4f %.4f N\n",
                status, out.wind_speed_h, out.wind_speed_up, out.force_ned[0], out.force_ned[1], out.force_ned[2]);
    return status == 0 ? 0 : 2;
}
