"""The mutation suite's mutants, as data: where each one applies and what it changes.

A C mutant is anchored on a REGION of the generated source (a labelled section such as ``validate``,
``commit`` or ``external_force``; ``kernel:<name>`` for a single-precision kernel; ``file`` for all of it)
and, inside it, either on a regular expression or on a LITERAL NEAR A MODEL VALUE (m*g, the observer
rate, a validation limit): both survive rewrites of the surrounding arithmetic. Every anchor must
match exactly ``count`` times, or the runner stops: a mutation that does not apply is not caught.
When the generated C changes shape, re-anchor here; the runner needs no change.

A model mutant replaces one exact piece of a module's source text before the tests import it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from dobwind.model.airframe import Airframe
from dobwind.model.kinds import DragFrame
from dobwind.model.plausibility import MAX_ACCELERATION_MPS2, MAX_GROUND_SPEED_MPS, MAX_THRUST_TO_WEIGHT
from dobwind.model.status import DT_TOLERANCE, QUATERNION_NORM_TOLERANCE, REJECTED_MASK
from dobwind.model.settling import settling_time_s

BOTH = ("single", "double")


@dataclass(frozen=True)
class CMutant:
    name: str
    region: str                      # section label, "kernel:<name>" or "file"
    pattern: str = ""                # regex; replaced by ``replacement`` ({real} = float/double)
    replacement: str = ""
    near: float | None = None        # instead of a pattern: the literal(s) within 1e-6 relative of this
    scale: float | None = None       # ... multiplied by this
    value: float | None = None       # ... or replaced by this
    count: int | None = 1            # None: at least once (a constant the C may repeat)
    precisions: tuple[str, ...] = BOTH


@dataclass(frozen=True)
class ModelMutant:
    name: str
    module: str   # dotted module name, e.g. dobwind.model.dynamics
    old: str      # exact source text, present exactly once
    new: str


# The tests that model mutants run: the step against an independent transcription, its physics,
# and the closed-form pins of the limits and of the heading.
MODEL_TESTS = ("tests/test_model.py", "tests/test_limits_pinned.py")


def c_mutants(af: Airframe) -> list[CMutant]:
    """Every C mutant for ``af``, in the order the table is reported."""
    return (_validation_mutants(af) + _estimate_mutants(af) + _commit_mutants() + _kernel_mutants()
            + _bias_mutants(af) + _header_mutants(af) + _plausibility_mutants(af) + _quick_mutants(af) + _envelope_mutants(af)
            + _tracked_airflow_mutants(af))


def _validation_mutants(af: Airframe) -> list[CMutant]:
    """Limits, operators, dropped tests and status bits of the validation."""
    cos_tilt = math.cos(math.radians(af.limits.max_tilt_deg))
    q_lo, q_hi = (1 - QUATERNION_NORM_TOLERANCE) ** 2, (1 + QUATERNION_NORM_TOLERANCE) ** 2
    top_dt = af.limits.max_dt_s * (1 + DT_TOLERANCE)
    # The rejection tests are intervals of IEEE bit patterns (codegen/bitranges.py):
    # ``<prefix>within(<prefix>bits(in->dt), <prefix>bits(lo), <prefix>bits(hi))`` for both dt bounds. The
    # finiteness test is one loop over the inputs (limit - |x| on the bits, OR-ed). The quick test
    # (model/step.py, _quick_accept) repeats the dt, quaternion, tilt and plausibility limits (count=2): a
    # wrong limit is wrong in both, and one in the exact tests alone is only seen where the quick test refuses.
    # The tilt's threshold is a product, a value the exact tests read from the quick test: printed once.
    dt = r"\w+bits\(in->dt\), "
    return [
        CMutant("dt upper bound <= becomes <", "validate", rf"({dt}\w+bits\([^)]+\), )(\w+bits\([^)]+\))\)",
                r"\1(\2 - 1u))", count=2),
        CMutant("dt upper bound x1.001", "validate", near=top_dt, scale=1.001, count=2),
        CMutant("dt lower bound x10 (1e-5 -> 1e-4)", "validate", rf"({dt}\w+bits\()([^)]+)\)", r"\1\2 * ({real})10)",
                count=2),
        CMutant("dt lower bound <= becomes <", "validate", rf"({dt})(\w+bits\([^)]+\))", r"\1(\2 + 1u)", count=2),
        CMutant("input limit loosened (the magnitude bits halved)", "validate", r"- \(u & (.*)\);",
                r"- ((u & \1) >> 1);"),
        CMutant("input limit <= becomes <", "validate", r"(over \|= .+?) - \(u &", r"\1 - 1u - (u &"),
        CMutant("finiteness loop skips the last input", "validate", r"k < (\d+); \+\+k", r"k < \1 - 1; ++k"),
        CMutant("quaternion lower bound 0.81 -> 0.8", "validate", near=q_lo, value=0.8, count=2),
        CMutant("quaternion upper bound 1.21 -> 1.22", "validate", near=q_hi, value=1.22, count=2),
        CMutant("quaternion lower bound <= becomes <", "validate", r"(\w+bits\([ta]\d+\), )(\w+bits\(0\.81\d*f?\))",
                r"\1(\2 + 1u)", count=2, precisions=("double",)),
        CMutant("tilt threshold cos(max_tilt) -0.01", "validate", near=cos_tilt, value=cos_tilt - 0.01),
        CMutant("tilt test <= becomes <", "validate", r"\b([ta]\d+) <= ([ta]\d+)(?=;| &&)", r"\1 < \2", count=2,
                precisions=("double",)),
        *[CMutant(f"rpm check on rotor {i + 1} dropped", "validate",
                  rf"\(\w+bits\(in->rotor_rpm\[{i}\]\) <= [^|]+\|\| \(\w+bits\(in->rotor_rpm\[{i}\]\) == [^;]+;",
                  f"in->rotor_rpm[{i}] == in->rotor_rpm[{i}];") for i in range(af.thrust.rotors)
          if af.thrust.source == "rpm"],
        CMutant("BAD_THRUST bit dropped", "validate", r"\? 16 :", "? 0 :"),
        CMutant("TILT bit 8 -> 4", "validate", r"\? 8 :", "? 4 :"),
        CMutant("rejection resets no run_s", "validate", r"state->run_s = 0\.0f?;((?:\s*state->check_follows = 0\.0f?;)?\s*\*out = state->last;\s*return status;)",
                r"\1"),
        CMutant("rejection returns 0", "validate", r"return status;", "(void)status; return 0;"),
    ]


def _estimate_mutants(af: Airframe) -> list[CMutant]:
    """The estimate's physics, filter, force-air model, wind triangle and result check."""
    mg = af.mass_kg * af.gravity_mps2
    rate_half = af.observer.gains[0] / af.mass_kg / 2
    return [
        CMutant("m*g x1.001", "external_force", near=mg, scale=1.001),
        CMutant("m*g x1.0001 (single precision's m*g)", "external_force", near=mg, scale=1.0001),
        CMutant("gravity sign", "external_force", near=mg, scale=-1.0),
        CMutant("mass x1.01", "external_force", near=af.mass_kg, scale=1.01, count=3),
        CMutant("observer rate x2", "observer", near=rate_half, scale=2.0),
        CMutant("low-pass 2 pi -> pi", "low_pass", near=-2 * math.pi, scale=0.5),
        CMutant("force direction guard 1e-6 -> 1e-2", "force_air", near=1e-6, value=1e-2),
        CMutant("wind triangle sign", "wind", r"air_rel_ned\[0\] \+ v_filt_new\[0\]", "air_rel_ned[0] - v_filt_new[0]"),
        CMutant("wind_speed_up sign", "wind", r"wind_speed_up = (\w+);", r"wind_speed_up = -\1;"),
        CMutant("degrees per radian x1.01", "wind", near=180 / math.pi, scale=1.01),
        CMutant("settling time x1.1", "quality", near=settling_time_s(af), scale=1.1, count=None),
        CMutant("SETTLING bit dropped", "quality", r"\? 64\.0f? :", "? ({real})0 :"),
        CMutant("quaternion order in z_b (w*y -> x*y)", "attitude", r"in->q\[0\] \* in->q\[2\]", "in->q[1] * in->q[2]"),
        CMutant("result limit 1e30 x10", "check_result", r"<= (\w+bits)\(([\d.e+-]+f?)\)", r"<= \1(\2 * ({real})10)"),
        CMutant("result limit <= becomes <", "check_result", r"(\w+bits\(t\d+\)) <= (\w+bits\([\d.e+-]+f?\))", r"\1 < \2",
                precisions=("double",)),
    ]


def _commit_mutants() -> list[CMutant]:
    """The state commit and the outputs."""
    return [
        CMutant("NaN wind_from_deg output", "commit", r"state->last\.wind_from_deg = wind_from_deg;",
                "state->last.wind_from_deg = wind_from_deg + ({real})NAN;"),
        CMutant("NaN wind_sigma_h output", "commit", r"state->last\.wind_sigma_h = wind_sigma_h;",
                "state->last.wind_sigma_h = wind_sigma_h + ({real})NAN;"),
        CMutant("early return before the state commit", "file", r"(\n\s*/\* ---- commit)",
                "\n    *out = state->last;\n    return (int)quality_status;\\1"),
        CMutant("initialized never set", "commit", r"state->initialized = 1\.0f?;", "state->initialized = ({real})0;"),
        CMutant("vel_prev[1] from the wrong axis", "commit", r"state->vel_prev\[1\] = in->vel_ned\[1\];",
                "state->vel_prev[1] = in->vel_ned[0];"),
        CMutant("v_filt[2] commits the observer value", "commit", r"state->v_filt\[2\] = v_filt_new\[2\];",
                "state->v_filt[2] = v_obs_new[2];"),
    ]


def _kernel_mutants() -> list[CMutant]:
    """The single-precision kernels (codegen/kernels.py)."""
    return [
        CMutant("sincos: sine cubic coefficient x1.01", "kernel:sincos", near=-1.66666546e-1, scale=1.01,
                precisions=("single",)),
        CMutant("sincos: cosine quartic coefficient x1.01", "kernel:sincos", near=4.16666456e-2, scale=1.01,
                precisions=("single",)),
        CMutant("sincos: pi/2 head 1.57080078 -> 1.5703 (both uses)", "kernel:sincos", near=1.57080078, value=1.5703, count=2,
                precisions=("single",)),
        CMutant("expm1: cubic coefficient x1.01", "kernel:expm1_poly", near=0.166665494, scale=1.01,
                precisions=("single",)),
        CMutant("expm1: ln2 head x1.01", "kernel:expm1", near=0.693115234, scale=1.01, precisions=("single",)),
        CMutant("atan2: cubic coefficient x1.01", "kernel:atan2", near=-0.333316594, scale=1.01,
                precisions=("single",)),
        CMutant("atan2: pi/2 1.57079637 -> 1.5703", "kernel:atan2", near=1.57079637, value=1.5703,
                precisions=("single",)),
    ]


def _bias_mutants(af: Airframe) -> list[CMutant]:
    """The velocity-aided acceleration bias estimate, when the airframe has one."""
    if not af.observer.estimates_acceleration_bias:
        return []
    return [
        # Single precision multiplies by the reciprocal of a constant divisor (codegen/sections.py).
        CMutant("bias time constant / 2", "acceleration", near=af.observer.acceleration_bias_time_s, scale=0.5,
                precisions=("double",)),
        CMutant("bias time constant / 2 (its reciprocal x2)", "acceleration",
                near=1.0 / af.observer.acceleration_bias_time_s, scale=2.0, precisions=("single",)),
        CMutant("bias gate 0 < run_s becomes <=", "acceleration", r"0\.0f? < state->run_s", "({real})0 <= state->run_s"),
        # The acceleration check (model/biasgate.py): its constants, its comparison, its rejection writes.
        CMutant("acceleration check: SIGMAS^2 36 -> 30", "acceleration", near=36.0, value=30.0),
        CMutant("acceleration check: FLOOR^2 4 -> 5", "acceleration", near=4.0, value=5.0),
        CMutant("acceleration check: average over 0.2 s, not 0.1", "acceleration", near=0.1, value=0.2),
        CMutant("acceleration check: trips below the bound", "acceleration",
                r"(const int (t\d+) = )(t\d+) < (t\d+);(\n\s*const \w+ t\d+ = \(\2 \? 2048)", r"\g<1>\4 < \3;\5"),
        CMutant("acceleration check: a rejection does not advance the mean square", "check_result",
                r"state->acc_noise = acc_noise_new;", ""),
        CMutant("acceleration check: an invalid sample does not clear check_follows", "validate",
                r"state->check_follows = 0\.0f?;", ""),
        CMutant("acceleration check: a rejection does not advance vel_prev", "check_result",
                r"state->vel_prev\[0\] = in->vel_ned\[0\];", ""),
    ]


def _header_mutants(af: Airframe) -> list[CMutant]:
    """The header's macros (issue #37: nothing checked them): the self-test compares each with the model."""
    mask = f"0x{REJECTED_MASK:02X}u"
    return [
        CMutant("header: REJECTED_MASK loses NUMERIC (0x20)", "header", rf"(REJECTED_MASK ){mask}",
                rf"\g<1>0x{REJECTED_MASK & ~0x20:02X}u"),
        CMutant("header: EXTRAPOLATED 0x80 -> 0x40", "header", r"(STATUS_EXTRAPOLATED )0x80u", r"\g<1>0x40u"),
        CMutant("header: IMPLAUSIBLE 0x800 -> 0x400", "header", r"(STATUS_IMPLAUSIBLE )0x800u", r"\g<1>0x400u"),
        CMutant("header: SETTLING_TIME_S x1.1", "header", r"(SETTLING_TIME_S )([\d.e+-]+f?)", r"\g<1>(\2 * ({real})1.1)"),
    ]


def _plausibility_mutants(af: Airframe) -> list[CMutant]:
    """The IMPLAUSIBLE bounds (model/plausibility.py), crossed by the self-test's boundary rows."""
    out = [CMutant("plausible: ground speed bound x1.1", "validate", near=MAX_GROUND_SPEED_MPS ** 2, scale=1.21, count=2),
           CMutant("plausible: IMPLAUSIBLE bit dropped", "validate", r"\? 2048 :", "? 0 :")]
    if af.observer.acceleration == "ned":
        out.append(CMutant("plausible: acceleration bound x1.1", "validate", near=MAX_ACCELERATION_MPS2 ** 2, scale=1.21,
                           count=2))
    if af.thrust.source == "collective":
        out.append(CMutant("plausible: thrust bound x1.1", "validate",
                           near=MAX_THRUST_TO_WEIGHT * af.mass_kg * af.gravity_mps2, scale=1.1, count=2))
    # No rpm-bound mutant: for a thrust curve as strong as m300's, 1.5 max_rpm lies beyond the 10 g and
    # 4-weight bounds whatever the other inputs, so moving it changes no status (an equivalent mutant).
    return out


def _quick_mutants(af: Airframe) -> list[CMutant]:
    """The quick acceptance test (model/step.py, _quick_accept) wrong on its own, accepting a sample the
    exact tests reject: each must be seen, since the exact tests then never run for that sample. (One that
    refuses more is an equivalent mutant: the exact tests accept the sample after it.)"""
    out = [CMutant("quick test: accepts every sample", "validate", r"quick_accept = ([^;]*);", r"quick_accept = (\1) | 1;"),
           # yaw_ref's |x| <= 1e6 widened to every pattern below the sign bit, NaN and infinity too
           CMutant("quick test: yaw_ref's finiteness dropped", "validate",
                   r"(\w+bits\(a\d+\) <= )\w+bits\(1000000\.0f\)", r"\g<1>0x7fffffffu",
                   precisions=("single",)),
           CMutant("quick test: yaw_ref's finiteness dropped", "validate",
                   r"(\w+bits\(a\d+\) <= )\w+bits\(1000000\.0\)",
                   r"\g<1>UINT64_C(0x7fffffffffffffff)", precisions=("double",)),
           CMutant("quick test: its ground speed bound x1.1 (the exact one kept)", "validate",
                   r"(\w+bits\(a\d+\) <= \w+bits\()22500\.0(f?)\)", r"\g<1>27225.0\2)")]
    if af.thrust.source == "rpm":
        out.append(CMutant("quick test: rotor 2's bound admits negative rpm", "validate",
                           r"(\w+bits\(in->rotor_rpm\[1\]\)) <= (\w+bits\([^)]+\))(?= &&|;)", r"(\1 & 0x7fffffffu) <= \2",
                           precisions=("single",)))
    return out


def _envelope_mutants(af: Airframe) -> list[CMutant]:
    """EXTRAPOLATED's envelope bounds (issue #37's survivors), for an airframe fit gave an envelope."""
    env = af.envelope
    if env is None:
        return []
    out = [CMutant("envelope: force_h_max x1.01", "quality", near=env.force_h_max_n, scale=1.01, count=None)]
    for label, value in (("low", env.force_z_n[0]), ("high", env.force_z_n[1])):
        if value != 0.0:
            out.append(CMutant(f"envelope: force_z {label} x1.01", "quality", near=value, scale=1.01, count=None))
    return out


# The body-frame law's coefficients whose terms are linear in the airflow (model/forceair.py).
_LINEAR_DRAG_KEYS = ("l0", "l2c", "l2s", "lr", "lz")


def _tracked_airflow_mutants(af: Airframe) -> list[CMutant]:
    """The body-frame drag step's tracked airflow (state air_prev), for an airframe with that law: verify
    judges it through the force the law gives at it (harness/compare.py), which must still catch these
    where the law is well conditioned. Each changes the stored state only, not this sample's outputs."""
    if af.drag is None or af.drag.frame != DragFrame.BODY:
        return []
    store = r"state->air_prev\[{0}\] = air_body\[{0}\];"
    out = [
        CMutant("tracked airflow: air_prev store skipped", "commit",
                store.format(0) + r"\s*" + store.format(1) + r"\s*" + store.format(2), "(void)air_body;"),
        CMutant("tracked airflow: air_prev[2] store skipped", "commit", store.format(2), ""),
        CMutant("tracked airflow: air_prev[0] stores air_body[1]", "commit", store.format(0),
                "state->air_prev[0] = air_body[1];"),
        CMutant("tracked airflow: air_prev[2] + 0.01 m/s", "commit", store.format(2),
                "state->air_prev[2] = air_body[2] + ({real})0.01;"),
        CMutant("tracked airflow: stored airflow x1.01", "force_air", r"(air_body\[\d\] = )(t\d+);",
                r"\1\2 * ({real})1.01;", count=3),
    ]
    # A wrong last update, seen by the state only: air_body[2] takes the iterate before the chord step. On
    # a linear law Newton lands on the solution in one step and the chord step changes nothing (an
    # equivalent mutant), so only a law with a term that is not linear in the airflow gets it.
    if any(getattr(af.drag, k) != 0.0 for k in af.drag.keys() if k not in _LINEAR_DRAG_KEYS):
        out.append(CMutant("tracked airflow: air_body[2] without the chord step", "force_air",
                           r"(const \w+ (t\d+) = (t\d+) - t\d+;)((?:\n[^\n]*)*?\n\s*air_body\[2\] = )\2;",
                           r"\1\4\3;"))
    return out


def model_mutants() -> list[ModelMutant]:
    return [
        ModelMutant("gravity sign", "dobwind.model.dynamics", "+ mass * gravity * E3 + f_e)", "- mass * gravity * E3 + f_e)"),
        ModelMutant("observer factor 2 (paper)", "dobwind.model.discretization", "a = dt * (rate_per_s / 2)",
                    "a = dt * rate_per_s"),
        ModelMutant("quaternion order (x, y, z, w)", "dobwind.model.dynamics", "w, x, y, z = q[0], q[1], q[2], q[3]",
                    "x, y, z, w = q[0], q[1], q[2], q[3]"),
        ModelMutant("heading-frame sign", "dobwind.model.forceair", "n = -sin_yaw * force_ned[0]", "n = sin_yaw * force_ned[0]"),
        ModelMutant("yaw_from_quaternion with w*z - x*y", "dobwind.model.attitude", "np.arctan2(2 * (w * z + x * y)",
                    "np.arctan2(2 * (w * z - x * y)"),
        ModelMutant("MIN_DT_S 1e-5 -> 1e-4", "dobwind.model.status", "MIN_DT_S = 1e-5", "MIN_DT_S = 1e-4"),
        ModelMutant("DT_TOLERANCE 1e-4 -> 1e-3", "dobwind.model.status", "DT_TOLERANCE = 1e-4", "DT_TOLERANCE = 1e-3"),
        ModelMutant("quaternion tolerance 0.1 -> 0.2", "dobwind.model.status", "QUATERNION_NORM_TOLERANCE = 0.1",
                    "QUATERNION_NORM_TOLERANCE = 0.2"),
        ModelMutant("input limit 1e6 -> 1e7", "dobwind.model.status", "INPUT_MAGNITUDE_LIMIT = 1e6",
                    "INPUT_MAGNITUDE_LIMIT = 1e7"),
        ModelMutant("wind triangle sign", "dobwind.model.step", 'w = s["air_rel_ned"] + s["v_filt_new"]',
                    'w = s["air_rel_ned"] - s["v_filt_new"]'),
        ModelMutant("low-pass 2 pi -> pi", "dobwind.model.step", "(-2 * math.pi) * cutoff", "(-math.pi) * cutoff"),
        ModelMutant("heading to NED sign", "dobwind.model.forceair", "return cos_yaw * x - sin_yaw * y,",
                    "return cos_yaw * x + sin_yaw * y,"),
        # The acceleration check (the C and the reference would change together: only the transcription sees it).
        ModelMutant("acceleration check SIGMAS 6 -> 5", "dobwind.model.biasgate", "SIGMAS = 6.0", "SIGMAS = 5.0"),
        ModelMutant("acceleration check: the mean square takes in the whole square", "dobwind.model.biasgate",
                    "(ca.fmin(square, bound) - acc_noise)", "(square - acc_noise)"),
        ModelMutant("acceleration check: its average over 0.2 s", "dobwind.model.biasgate",
                    "fast = dt / (CHECK_TIME_S + dt)", "fast = dt / (2 * CHECK_TIME_S + dt)"),
    ]

