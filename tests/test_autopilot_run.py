"""The autopilot integrations run, not only compile: the PX4 module and the ArduPilot library that
`dobwind generate --target px4|ardupilot` writes, built with the host C++ compiler against fakes of the
autopilot APIs (tests/standins/run/: a uORB bus, a clock, the AHRS, the logger) and flown through a
scripted hover: on the ground, then airborne, level and at rest in still air.

What they must do (docs/integration.md, "the contract"): on the ground the ground's reaction force is not
wind, so no estimate is published there, and after take-off the estimator restarts and settles before its
wind is trusted; in a still-air hover the trusted wind is zero, and only status-0 samples reach the
autopilot's own wind (PX4's wind topic, ArduPilot's get_wind_NED)."""
from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness.build import run
from dobwind.model.airframe import Airframe, load_airframe, parse_airframe
from dobwind.model.airframe_toml import dumps
from tests.helpers import M300, airframe_dict
from tests.test_autopilot_targets import STANDINS, msg_header

SETTLING = 0x40
NONFINITE = 0x01
DT_S = 0.01
GROUND_S = 6.0   # longer than the m300's settling time (3.5 s): a run on the ground would be trusted by then
AIR_S = 8.0

pytestmark = pytest.mark.skipif(shutil.which("g++") is None or shutil.which("gcc") is None,
                                reason="needs the host gcc and g++")


@dataclass(frozen=True)
class Message:
    kind: str          # "D": the module's own message (every sample), "W": the autopilot's wind
    time_s: float      # the sample's time
    status: int        # "D" only
    wind: tuple[float, ...]


def hover_rpm(af: Airframe) -> float:
    """The rotor speed that carries the weight: scale * sum(c_i (rpm / max_rpm)^i) = m g / rotors."""
    t = af.thrust
    if t.source != "rpm":
        return 0.0
    per_rotor = af.mass_kg * af.gravity_mps2 / (t.rotors * t.scale)
    coefficients = np.array(t.coefficients, dtype=float)
    coefficients[0] -= per_rotor
    roots = np.polynomial.polynomial.polyroots(coefficients)
    omega = min(r.real for r in roots if abs(r.imag) < 1e-12 and r.real > 0)
    return float(omega * t.max_rpm)


def _parse(text: str) -> list[Message]:
    messages = []
    for line in text.splitlines():
        kind, time_us, *rest = line.split()
        if kind == "D":
            messages.append(Message(kind, int(time_us) * 1e-6, int(rest[0]), tuple(float(x) for x in rest[1:])))
        else:
            messages.append(Message(kind, int(time_us) * 1e-6, 0, tuple(float(x) for x in rest)))
    return messages


def _build_step(folder: Path, out: Path) -> Path:
    step = next(folder.glob("*_wind.c"))
    run(["gcc", "-std=c99", "-O2", "-c", str(step), "-o", str(out)])
    return out


def fly_px4(af: Airframe, tmp_path: Path, fault: tuple[str, ...] = ()) -> list[Message]:
    folder = tmp_path / "gen" / "px4"
    write_files(generate_code(af, "single", target="px4").files, tmp_path / "gen")
    topics = tmp_path / "msg" / "uORB" / "topics"
    topics.mkdir(parents=True)
    (topics / "dob_wind.h").write_text(msg_header((folder / "msg" / "DobWind.msg").read_text(), "dob_wind"))
    exe = tmp_path / "px4_run"
    run(["g++", "-std=gnu++14", "-O1", f'-DMODULE_NAME="dobwind_{af.name}"', f"-I{folder}", f"-I{tmp_path / 'msg'}",
         f"-I{STANDINS / 'px4'}", str(STANDINS / "run" / "px4_run.cpp"), str(_build_step(folder, tmp_path / "step.o")),
         "-lm", "-o", str(exe)])
    rotors = af.thrust.rotors if af.thrust.source == "rpm" else 0
    return _parse(run([str(exe), str(DT_S), str(GROUND_S), str(AIR_S), repr(hover_rpm(af)), str(rotors), *fault]).stdout)


def fly_ardupilot(af: Airframe, tmp_path: Path, ground_s: float = GROUND_S, fault: tuple[str, ...] = ()) -> list[Message]:
    folder = tmp_path / "gen" / "AP_DOBWind"
    write_files(generate_code(af, "single", target="ardupilot").files, tmp_path / "gen")
    exe = tmp_path / "ardupilot_run"
    run(["g++", "-std=gnu++11", "-O1", f"-I{folder}", f"-I{folder.parent}", f"-I{STANDINS / 'ardupilot'}",
         str(STANDINS / "run" / "ardupilot_run.cpp"), str(_build_step(folder, tmp_path / "step.o")), "-lm", "-o", str(exe)])
    rotors = af.thrust.rotors if af.thrust.source == "rpm" else 0
    return _parse(run([str(exe), str(DT_S), str(ground_s), str(AIR_S), repr(hover_rpm(af)), str(rotors), *fault]).stdout)


def _check_only_trusted_wind_reaches_the_autopilot(messages: list[Message]) -> None:
    trusted = {round(m.time_s, 6) for m in messages if m.kind == "D" and m.status == 0}
    winds = [m for m in messages if m.kind == "W"]
    assert winds, "no trusted wind"
    untrusted = [m for m in winds if round(m.time_s, 6) not in trusted]
    assert not untrusted, f"wind given for samples without a status-0 estimate: {untrusted[:3]}"


def _check_ground_then_hover(messages: list[Message]) -> None:
    own = [m for m in messages if m.kind == "D"]
    assert own, "nothing published"
    on_ground = [m for m in messages if m.time_s <= GROUND_S + 1e-9]
    assert not on_ground, f"published on the ground: {on_ground[:3]}"
    assert own[0].status & SETTLING, f"the first airborne estimate is not SETTLING: {own[0]}"
    last = own[-1]
    assert last.status == 0 and max(abs(w) for w in last.wind) < 0.05, last  # a still-air hover, settled
    _check_only_trusted_wind_reaches_the_autopilot(messages)


# The inputs each integration reads differ by the thrust source and the acceleration input. Neither has a
# force offset: at rest in still air the force is zero, and so is the wind.
AIRFRAMES = {
    "m300 (rpm, NED acceleration)": None,
    "collective, specific force": airframe_dict(**{"thrust": {"source": "collective"},
                                                   "observer.acceleration": "specific_force",
                                                   "observer.force_offset": None}),
}


def _airframe(variant: str) -> Airframe:
    doc = AIRFRAMES[variant]
    return load_airframe(M300) if doc is None else parse_airframe(dumps(doc), "<test>")


@pytest.mark.parametrize("variant", AIRFRAMES)
def test_px4_module_publishes_nothing_on_the_ground_and_settles_after_take_off(tmp_path, variant):
    _check_ground_then_hover(fly_px4(_airframe(variant), tmp_path))


# The replay of a PX4 log reads an ESC report older than this as no data (dobwind/io/resample.py); the module
# must read its esc_status alike, or the onboard wind and `replay --px4-wind` of the same flight differ.
ESC_MAX_AGE_S = 0.75


@pytest.mark.parametrize("fault", ["stop", "offline", "zero"])
def test_px4_module_rejects_rotor_speeds_replay_reads_as_no_data(tmp_path, fault):
    """From FAULT_S on, ESC 1's telemetry fails: esc_status stops (the module would hold its last report for
    ever), says ESC 1 is offline (esc_online_flags), or reads 0 rpm for it in flight. As replay reads such rows
    (dobwind/io/ulog.py esc_missing), the module's samples are then rejected (NONFINITE: a NaN rpm) and the
    standard wind topic gets nothing; before, it is the settled hover. A stop is held for ESC_MAX_AGE_S."""
    from dobwind.io.resample import ROTOR_MAX_GAP_S

    assert ESC_MAX_AGE_S == ROTOR_MAX_GAP_S
    fault_s = GROUND_S + AIR_S - 2.0
    messages = fly_px4(_airframe("m300 (rpm, NED acceleration)"), tmp_path, (repr(fault_s), fault))
    grace = ESC_MAX_AGE_S if fault == "stop" else 0.0
    before = [m for m in messages if m.time_s <= fault_s]
    after = [m for m in messages if m.time_s > fault_s + grace + DT_S / 2]
    assert before and before[-1].kind == "W" and before[-2].status == 0  # settled before the fault
    assert after and all(m.kind == "D" and m.status & NONFINITE for m in after), after[:3]
    if fault == "stop":  # the held report is used while it is recent
        held = [m for m in messages if fault_s < m.time_s <= fault_s + grace - DT_S / 2]
        assert held and all(m.status == 0 for m in held if m.kind == "D")


def test_ardupilot_library_gives_no_wind_before_its_first_estimate(tmp_path):
    """get_wind_NED() is true only for a status-0 estimate: not at the first update(), which only starts the
    clock (no step has run: the output is the constructor's zeros, which read as a trusted calm)."""
    _check_only_trusted_wind_reaches_the_autopilot(fly_ardupilot(_airframe("m300 (rpm, NED acceleration)"),
                                                                 tmp_path, ground_s=0.0))


@pytest.mark.parametrize("variant", AIRFRAMES)
def test_ardupilot_library_logs_nothing_on_the_ground_and_settles_after_take_off(tmp_path, variant):
    _check_ground_then_hover(fly_ardupilot(_airframe(variant), tmp_path))


def test_ardupilot_library_rejects_a_rotor_reading_0_rpm_in_flight(tmp_path):
    """As replay reads a DataFlash log (dobwind/io/dataflash.py: an ESC at 0 rpm while airborne is no data), a
    rotor whose telemetry reads 0 rpm in flight goes in as NaN: rejected (NONFINITE), no wind from
    get_wind_NED(). (A stale report ArduPilot's get_rpm() itself refuses.)"""
    fault_s = GROUND_S + AIR_S - 2.0
    messages = fly_ardupilot(_airframe("m300 (rpm, NED acceleration)"), tmp_path, fault=(repr(fault_s), "zero"))
    before = [m for m in messages if m.time_s <= fault_s]
    after = [m for m in messages if m.time_s > fault_s + DT_S / 2]
    assert before and before[-1].kind == "W" and before[-2].status == 0  # settled before the fault
    assert after and all(m.kind == "D" and m.status & NONFINITE for m in after), after[:3]
