/*
 * m300_step.c - the m300 polynomial step written by hand: the yardstick of `make bench` for the
 * generated step (issue #32: the generated step within 1.10x of it in x86 instructions and flash).
 *
 * What an engineer would write for this one airframe, with the constants folded by hand and the same
 * math and outputs as the generated step: attitude, thrust power sums, the velocity-aided acceleration
 * bias, the external force, the paper's observer, the scheduled low-pass, the polynomial force-air
 * law, the wind triangle, the quality bits and the result check. The sin/cos, expm1 and atan2 kernels
 * are the generated file's (included below with its step renamed): the yardstick measures the step,
 * not the kernels.
 *
 * Three limits from this one file:
 * - default: without the input validation (the limit the issue quoted predates it);
 * - -DHANDWRITTEN_VALIDATION: with the same tests and status bits as the generated validation, written
 *   by hand: finiteness, dt, quaternion norm, tilt, negative and implausible inputs; each decided on the
 *   IEEE bits, as the generated code does, so that the autopilots' flags cannot change a decision.
 * - -DHANDWRITTEN_VALIDATION -DHANDWRITTEN_ACC_CHECK: and the acceleration check (model/biasgate.py), which
 *   the generated step has had since the two limits above were written: the disagreement of the
 *   acceleration with the velocity's derivative averaged over 0.1 s, against 6 sigma of its own mean
 *   square (IMPLAUSIBLE), and the check's state advanced on every validated sample, accepted or not. The
 *   same work as the generated step: the like-for-like yardstick (issue #32).
 * benchmarks/bench.py builds each, checks their outputs against the Python reference, and prints them.
 */
#define m300_wind_step m300_wind_step_generated
#define m300_wind_init m300_wind_init_generated
#include "m300_wind.c"
#undef m300_wind_step
#undef m300_wind_init

/* x's place in the IEEE order as an integer; a NaN above every number (nan_high) or below: the NaN-exact
 * tests of the rejection bits and the result check. The generated file defined it until its tests became
 * bit-pattern intervals (issue #32); the same function, kept here. x86: the same instructions as before;
 * M4F: the limit without validation now inlines its one call (3,316 B of firmware, 48 B less), the one with
 * validation calls it (3,904 B, 4 B more). */
static int32_t m300_wind_key(float x, int nan_high)
{
    const uint32_t u = m300_wind_bits(x);
    const uint32_t magnitude = u & 0x7fffffffu;
    const int32_t nan_key = (int32_t)(0x7f800000u + 1u);
    if (magnitude > 0x7f800000u) {
        return nan_high ? nan_key : -nan_key;
    }
    return (u >> 31) != 0u ? -(int32_t)magnitude : (int32_t)magnitude;
}

#define SETTLE_S 3.5056181f /* settling time, held as a float as the generated step holds it */

void m300_wind_init(m300_wind_state_t *state)
{
    memset(state, 0, sizeof *state);
    state->last.wind_sigma_h = state->last.wind_sigma_up = -1.0f; /* unknown before the first estimate */
}

#ifdef HANDWRITTEN_VALIDATION
static int32_t hw_sbits(float x) /* raw bits, signed: orders finite x against a positive constant */
{
    int32_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

/* The status bits of a rejected sample, NaN-exact (each test fails for NaN as the reference's). */
static int hw_reject_bits(const m300_wind_input_t *in, int finite)
{
    const float n2 = in->q[0] * in->q[0] + in->q[1] * in->q[1] + in->q[2] * in->q[2] + in->q[3] * in->q[3];
    const float r33 = in->q[0] * in->q[0] - in->q[1] * in->q[1] - in->q[2] * in->q[2] + in->q[3] * in->q[3];
    const float v2 = in->vel_ned[0] * in->vel_ned[0] + in->vel_ned[1] * in->vel_ned[1] + in->vel_ned[2] * in->vel_ned[2];
    const float a2 = in->acc_ned[0] * in->acc_ned[0] + in->acc_ned[1] * in->acc_ned[1] + in->acc_ned[2] * in->acc_ned[2];
    int status = finite ? 0 : 1;
    int k, negative = 0, implausible = 0;
    status |= (m300_wind_key(in->dt, 0) >= m300_wind_key(1.00000007e-05f, 0) &&
               m300_wind_key(in->dt, 1) <= m300_wind_key(0.100009993f, 1)) ? 0 : 2;
    status |= (m300_wind_key(n2, 0) >= m300_wind_key(0.810000002f, 0) &&
               m300_wind_key(n2, 1) <= m300_wind_key(1.20999992f, 1)) ? 0 : 4;
    status |= 0.5f * n2 <= r33 ? 0 : 8;
    for (k = 0; k < 4; ++k) {
        negative |= !(m300_wind_key(in->rotor_rpm[k], 0) >= 0);
        implausible |= m300_wind_key(in->rotor_rpm[k], 0) > m300_wind_key(18000.0f, 0);
    }
    implausible |= m300_wind_key(v2, 0) > m300_wind_key(22500.0f, 0);
    implausible |= m300_wind_key(a2, 0) > m300_wind_key(9617.03809f, 0);
    return status | (negative ? 16 : 0) | (implausible ? 2048 : 0);
}

/* 0 when the sample passes every test (the fast path), else its status bits. */
static int hw_validate(const m300_wind_input_t *in)
{
    uint32_t over = 0u, u;
    int k, ok;
    for (k = 0; k < 16; ++k) { /* |x| <= 1e6 for every input, on the bits */
        memcpy(&u, (const unsigned char *)in + 4 * k, sizeof u);
        over |= 0x49742400u - (u & 0x7fffffffu);
    }
    {
        const float n2 = in->q[0] * in->q[0] + in->q[1] * in->q[1] + in->q[2] * in->q[2] + in->q[3] * in->q[3];
        const float r33 = in->q[0] * in->q[0] - in->q[1] * in->q[1] - in->q[2] * in->q[2] + in->q[3] * in->q[3];
        const float v2 = in->vel_ned[0] * in->vel_ned[0] + in->vel_ned[1] * in->vel_ned[1] + in->vel_ned[2] * in->vel_ned[2];
        const float a2 = in->acc_ned[0] * in->acc_ned[0] + in->acc_ned[1] * in->acc_ned[1] + in->acc_ned[2] * in->acc_ned[2];
        ok = (over >> 31) == 0u;
        ok &= hw_sbits(in->dt) >= hw_sbits(1.00000007e-05f) && hw_sbits(in->dt) <= hw_sbits(0.100009993f);
        ok &= hw_sbits(n2) >= hw_sbits(0.810000002f) && hw_sbits(n2) <= hw_sbits(1.20999992f);
        ok &= 0.5f * n2 <= r33;
        ok &= hw_sbits(v2) <= hw_sbits(22500.0f) && hw_sbits(a2) <= hw_sbits(9617.03809f);
        for (k = 0; k < 4; ++k) { /* 0 <= rpm <= 18000, -0 included */
            ok &= (uint32_t)hw_sbits(in->rotor_rpm[k]) + 0x7fffffffu >= 0x7fffffffu && hw_sbits(in->rotor_rpm[k]) <= hw_sbits(18000.0f);
        }
    }
    return ok ? 0 : hw_reject_bits(in, (over >> 31) == 0u);
}
#endif

int m300_wind_step(m300_wind_state_t *state, const m300_wind_input_t *in, m300_wind_output_t *out)
{
    const float *v = in->vel_ned, *q = in->q, *w = in->rotor_rpm;
    float f_e[3], f_obs[3], v_obs[3], f_filt[3], v_filt[3], bias[3], wind[3];
    int i;
#ifdef HANDWRITTEN_ACC_CHECK
    float check[3], noise;
    int implausible;
#endif
#ifdef HANDWRITTEN_VALIDATION
    {
        const int rejected = hw_validate(in);
        if (rejected) {
            state->run_s = 0.0f;
#ifdef HANDWRITTEN_ACC_CHECK
            state->check_follows = 0.0f; /* the next sample's vel_prev is not its predecessor's */
#endif
            *out = state->last;
            return rejected;
        }
    }
#endif
    {
        /* thrust from the rotor power sums; z_b from the (near-unit) quaternion */
        const float s1 = w[0] + w[1] + w[2] + w[3];
        const float s2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2] + w[3] * w[3];
        const float u_f = 0.0526f + 0.000945f * s1 + 1.4375e-06f * s2;
        const float q00 = q[0] * q[0], q11 = q[1] * q[1], q22 = q[2] * q[2], q33 = q[3] * q[3];
        const float uq = u_f / (q00 + q11 + q22 + q33);
        const float uz[3] = {2.0f * (q[1] * q[3] + q[0] * q[2]) * uq, 2.0f * (q[2] * q[3] - q[0] * q[1]) * uq,
                             (q00 - q11 - q22 + q33) * uq};
        /* acceleration bias: the input minus the velocity's derivative, averaged over 20 s (not across a gap) */
#ifdef HANDWRITTEN_ACC_CHECK
        const float slow = -m300_wind_expm1(in->dt * -0.05f); /* 20 s: the bias's and the check's mean square */
        const float gain = state->run_s > 0.0f ? slow : 0.0f;
        const float fast = state->check_follows * (in->dt / (0.1f + in->dt)); /* 0.1 s, backward Euler */
        float square = 0.0f, bound;
#else
        const float gain = state->run_s > 0.0f ? -m300_wind_expm1(in->dt * -0.05f) : 0.0f;
#endif
        const float inv_dt = 1.0f / in->dt;
        /* observer (paper form, lambda/m = 6.25 1/s) and the low-pass scheduled on the last wind speed */
        const float b0 = state->initialized * (3.125f * in->dt) + (1.0f - state->initialized);
        const float pole = state->initialized * (1.0f - 3.125f * in->dt);
        const float sh = state->last.wind_speed_h;
        const float lo = sh > 0.0f ? (sh < 3.0f ? sh : 3.0f) : 0.0f, hi = sh > 3.0f ? (sh < 10.0f ? sh : 10.0f) : 3.0f;
        const float cutoff = 0.2f + 0.05f * lo + 0.0214285714f * (hi - 3.0f);
        const float alpha = (1.0f - state->initialized) - state->initialized * m300_wind_expm1(-6.28318531f * cutoff * in->dt);
        for (i = 0; i < 3; ++i) {
            const float acc = in->acc_ned[i] - state->acc_bias[i];
#ifdef HANDWRITTEN_ACC_CHECK
            const float e = (in->acc_ned[i] - (v[i] - state->vel_prev[i]) * inv_dt) - state->acc_bias[i];
            bias[i] = state->acc_bias[i] + gain * e;
            check[i] = state->acc_check[i] + fast * (e - state->acc_check[i]);
            square += check[i] * check[i];
#else
            bias[i] = state->acc_bias[i] + gain * ((in->acc_ned[i] - (v[i] - state->vel_prev[i]) * inv_dt) - state->acc_bias[i]);
#endif
            f_e[i] = 8.0f * acc + uz[i] - (i == 2 ? 78.4532f : 0.0f); /* m g, down */
            f_obs[i] = pole * state->f_obs[i] + b0 * f_e[i];
            v_obs[i] = pole * state->v_obs[i] + b0 * v[i];
            f_filt[i] = (1.0f - alpha) * state->f_filt[i] + alpha * f_obs[i];
            v_filt[i] = (1.0f - alpha) * state->v_filt[i] + alpha * v_obs[i];
        }
#ifdef HANDWRITTEN_ACC_CHECK
        bound = 36.0f * state->acc_noise + 4.0f; /* (6 sigma)^2 of the mean square, and a floor of (2 m/s^2)^2 */
        implausible = bound < square;
        noise = state->acc_noise + state->check_follows * slow * ((square < bound ? square : bound) - state->acc_noise);
#endif
    }
    {
        /* heading-frame force -> airflow speed (the paper's surface), along the force; wind triangle */
        const m300_wind_sincos_t cs = m300_wind_sincos(in->yaw_ref);
        const float m = cs.c * f_filt[0] + cs.s * f_filt[1], n = cs.c * f_filt[1] - cs.s * f_filt[0];
        const float poly = 0.9f + 0.06f * m + 0.16f * n + 0.09f * m * m + 0.07f * n * n;
        const float k = (poly > 0.0f ? poly : 0.0f) / sqrtf(m * m + n * n + 1e-06f);
        float from, sum;
        int status;
        wind[0] = k * f_filt[0] + v_filt[0];
        wind[1] = k * f_filt[1] + v_filt[1];
        wind[2] = 0.5f * f_filt[2] + v_filt[2];
        out->wind_speed_h = sqrtf(wind[0] * wind[0] + wind[1] * wind[1]);
        from = 57.2957795f * m300_wind_atan2(-wind[1], -wind[0]);
        from += from < 0.0f ? 360.0f : 0.0f;
        /* result check: everything committed must be finite (NaN-exact on the bits) */
        sum = out->wind_speed_h;
        for (i = 0; i < 3; ++i) {
            sum += fabsf(f_filt[i]) + fabsf(wind[i]) + fabsf(bias[i]);
        }
#ifdef HANDWRITTEN_ACC_CHECK
        status = !(m300_wind_key(sum, 1) <= m300_wind_key(9.99999939e+29f, 1)) ? 32 : (implausible ? 2048 : 0);
        if (status) { /* validated, so the check follows this sample even though it is rejected */
            state->run_s = 0.0f;
            state->check_follows = 1.0f;
            for (i = 0; i < 3; ++i) {
                state->acc_check[i] = check[i];
                state->vel_prev[i] = v[i];
            }
            state->acc_noise = noise;
            *out = state->last;
            return status;
        }
        for (i = 0; i < 3; ++i) {
            state->acc_check[i] = check[i];
        }
        state->acc_noise = noise;
        state->check_follows = 1.0f;
#else
        if (!(m300_wind_key(sum, 1) <= m300_wind_key(9.99999939e+29f, 1))) {
            state->run_s = 0.0f;
            *out = state->last;
            return 32;
        }
#endif
        state->run_s = state->run_s + in->dt < SETTLE_S ? state->run_s + in->dt : SETTLE_S;
        status = (state->run_s < SETTLE_S ? 64 : 0) + (wind[0] * wind[0] + wind[1] * wind[1] + wind[2] * wind[2] > 2500.0f ? 128 : 0);
        for (i = 0; i < 3; ++i) {
            state->f_obs[i] = f_obs[i];
            state->v_obs[i] = v_obs[i];
            state->f_filt[i] = out->force_ned[i] = f_filt[i];
            state->v_filt[i] = v_filt[i];
            state->vel_prev[i] = v[i];
            state->acc_bias[i] = bias[i];
            out->wind_ned[i] = wind[i];
        }
        out->wind_speed_up = -wind[2];
        out->wind_from_deg = from >= 360.0f ? 0.0f : from;
        out->wind_sigma_h = out->wind_sigma_up = -1.0f;
        state->last = *out;
        state->initialized = 1.0f;
        return status;
    }
}
