"""The acceleration check: a glitch of the acceleration input is rejected (IMPLAUSIBLE) before it enters
the observer or the velocity-aided bias estimate.

An airframe with a velocity-aided bias estimate (observer.acceleration_bias_time > 0, an acceleration input)
already forms, on every sample, the disagreement ``e = a_measured - bias - (v - v_prev) / dt``. A real force
moves the measured acceleration and the velocity's derivative alike, so e is noise (vibration, the logs'
timing) plus the bias the estimate has not caught yet. A logging glitch moves one of them only: 0.5 s of
-5 m/s^2 on all axes is |e| = 8.7 m/s^2 for 0.5 s. Accepted, that glitch read as a 40 N force per axis on an
8 kg vehicle, and the 20 s bias estimate took in part of it: the wind was still 0.3-0.4 m/s off, and trusted,
20 s later (issue #37, class 5).

The check (three state fields, advanced on every sample that passes validation, accepted or not):

- ``acc_check``: e averaged over CHECK_TIME_S (its noise averaged down, a glitch seen within a few samples);
- ``acc_noise``: the mean square of ``acc_check`` over NOISE_TIME_S: what this log's e looks like;
- ``check_follows``: 1 when ``vel_prev`` is the previous sample's velocity (that sample passed validation),
  0 after a sample that did not (then e cannot be formed, and ``acc_check`` holds).

A sample is IMPLAUSIBLE when ``|acc_check|^2 > SIGMAS^2 acc_noise + FLOOR^2``: far outside this log's own
spread. The bound scales with the log because real logs differ by an order of magnitude (the PX4 logs of
the shared data, e averaged over 0.1 s after the bias: median 0.04-2.9 m/s^2, 99th percentile
0.08-12 m/s^2 at 50 Hz), so no fixed bound both catches the glitch on a clean log and passes a vibrating
one. A rejected sample adds the bound itself to ``acc_noise``, not its own square (winsorised): a glitch
of T seconds multiplies the bound by about exp((SIGMAS^2 - 1) T / NOISE_TIME_S), 2.4-fold for 0.5 s at any
sample rate, not to the glitch's own size, while a lasting change of the inputs (a new bias, a vibrating
flight phase) raises it by that same law until it is accepted: the check cannot lock the estimator out
(the closed form: tests/test_hardening.py). Like every
rejection it restarts SETTLING: the few glitched samples the average needs before it trips were
accepted, and their transient passes within one settling time.

A velocity that steps (an EKF reset) trips the check too: its derivative is a spike the acceleration
does not show.
"""
from __future__ import annotations

import casadi as ca

from dobwind.model.status import STATUS_BITS

# Time constant (s) of the fast average: a few samples at any supported rate, far shorter than any observer.
CHECK_TIME_S = 0.1
# Time constant (s) of the mean square: long against a glitch (0.5 s of one raises the bound by a factor
# of about 2.4 at any rate, not to the glitch's own size), short enough to learn a log's spread in its
# first seconds of flight.
NOISE_TIME_S = 20.0
# How far outside the log's own spread (in standard deviations of the averaged disagreement) a sample is.
SIGMAS = 6.0
# The least bound (m/s^2): a log whose disagreement is almost noise-free (a simulator's) still accepts the
# inputs' rounding and the bias estimate's catching up; 0.2 g.
FLOOR_MPS2 = 2.0

STATE_FIELDS = ("acc_check", "acc_noise", "check_follows")
IMPLAUSIBLE_BIT = next(bit.value for bit in STATUS_BITS if bit.name == "IMPLAUSIBLE")


def check(disagreement: ca.SX, dt: ca.SX, acc_check: ca.SX, acc_noise: ca.SX, follows: ca.SX) -> dict[str, ca.SX]:
    """The next check state and this sample's verdict (0, or the IMPLAUSIBLE bit). ``disagreement``: e (NED, m/s^2);
    ``follows``: exactly 0 or 1 (``state.check_follows``)."""
    # The fast average's weight in backward-Euler form, dt / (T + dt): like the exact 1 - exp(-dt / T) it lies
    # in (0, 1) for every dt and averages over about T; the detector needs no more, and a division costs
    # less than an exponential (the step's instructions, issue #32).
    fast = dt / (CHECK_TIME_S + dt)
    slow = -ca.expm1(-dt / NOISE_TIME_S)
    averaged = acc_check + follows * fast * (disagreement - acc_check)
    square = ca.sumsqr(averaged)
    bound = SIGMAS * SIGMAS * acc_noise + FLOOR_MPS2 * FLOOR_MPS2
    trips = square > bound
    # A sample beyond the bound adds the bound only (winsorised); one that did not follow a validated
    # sample adds nothing (its disagreement is unknown).
    noise = acc_noise + follows * slow * (ca.fmin(square, bound) - acc_noise)
    # The verdict leaves the stage as the status value itself (a float 0 or IMPLAUSIBLE): a truth value
    # crossing stages would be tested with "!= 0" on a float in the C (-Wfloat-equal).
    return {"acc_check_new": averaged, "acc_noise_new": noise,
            "acc_status": ca.if_else(trips, IMPLAUSIBLE_BIT, 0)}
