"""Issue #37: physical plausibility in the step (IMPLAUSIBLE), recovery after glitches, generate's
self-test gate, special files refused by type, stdout errors and failed designs on one line."""
from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.io.inputs import step_inputs
from dobwind.io.logs import FlightLog
from dobwind.model import plausibility as P
from dobwind.model import reference
from dobwind.model.airframe import load_airframe
from dobwind.model.errors import CheckFailed
from dobwind.model.status import REJECTED_MASK, STATUS_BITS
from dobwind.model.step import build_step
from dobwind.simulate.simulate import simulate
from tests.helpers import M300, ROOT

BITS = {b.name: b.value for b in STATUS_BITS}
IMPLAUSIBLE, EXTRAPOLATED = BITS["IMPLAUSIBLE"], BITS["EXTRAPOLATED"]
HAS_CC = shutil.which(os.environ.get("CC", "cc")) is not None


def test_implausible_is_the_preallocated_rejection_bit():
    assert IMPLAUSIBLE == 1 << 11 and REJECTED_MASK & IMPLAUSIBLE
    assert not REJECTED_MASK & EXTRAPOLATED  # the wind bound is a quality flag, never a rejection


@pytest.mark.parametrize("signal, size, bound", [
    ("in.vel_ned", 3, P.MAX_GROUND_SPEED_MPS),
    ("in.acc_ned", 3, P.MAX_ACCELERATION_MPS2),
    ("in.specific_force", 3, P.MAX_ACCELERATION_MPS2),
    ("in.rotor_rpm", 4, P.MAX_RPM_FRACTION * 1000.0),
    ("in.thrust", 1, P.MAX_THRUST_TO_WEIGHT * 2.0 * 9.81),
])
def test_each_input_bound_flips_at_its_documented_value(signal, size, bound):
    """Vector bounds are on the norm: (b/sqrt(3)) * 1.01 on each axis crosses, 0.99 does not."""
    s = {"in.vel_ned": ca.SX.zeros(3), signal: ca.SX.sym("x", size)}
    f = ca.Function("f", [s[signal]], [P.implausible_inputs(s, 2.0, 9.81, 1000.0)])
    per_axis = bound / np.sqrt(size) if size == 3 else bound
    assert not bool(f(np.full(size, 0.99 * per_axis)))
    assert bool(f(np.full(size, 1.01 * per_axis)))
    assert not bool(f(np.full(size, np.nan)))  # NaN is NONFINITE's, not a plausibility question


def _simulated(af, hold_s=2.0):
    model = build_step(af)
    inputs = step_inputs(model, FlightLog("sim", simulate(af, "outdoor", seed=1, hold_s=hold_s)))
    return model, inputs


def _wind(traj):
    return traj.outputs[:, 3:6]


def _rows(model, inputs: np.ndarray, start: int, seconds: float) -> int:
    """How many rows from ``start`` on the log's own clock (its dt column) take to span ``seconds``: the
    simulated log is sampled at its own jittered rate, not at the airframe's nominal sample time."""
    elapsed = np.cumsum(inputs[start:, model.inputs.slice("dt")].ravel())
    return int(np.searchsorted(elapsed, seconds - 1e-9)) + 1


@pytest.mark.parametrize("airframe", ["m300", "nf_quad"])
def test_velocity_glitch_is_rejected_and_the_estimate_recovers_within_one_settling_time(airframe):
    """0.5 s of ground velocity at 1e6 m/s (inside NONFINITE's 1e6): before, 1,000 trusted rows up to 2.5e9 m/s
    and no recovery; now every glitch row is IMPLAUSIBLE and one settling time later the estimate is the
    clean run's."""
    model, clean_in = _simulated(load_airframe(ROOT / "airframes" / f"{airframe}.toml"))
    start = len(clean_in) // 3
    length = _rows(model, clean_in, start, 0.5)
    glitch = clean_in.copy()
    glitch[start:start + length, model.inputs.slice("vel_ned")] = 1e6
    clean, hit = reference.run(model, clean_in), reference.run(model, glitch)
    assert np.all(hit.status[start:start + length] & IMPLAUSIBLE)
    trusted = hit.status == 0
    assert np.all(np.linalg.norm(_wind(hit)[trusted], axis=1) <= P.MAX_WIND_MPS)
    after = start + length + _rows(model, clean_in, start + length, model.settling_time_s)
    assert np.abs(_wind(hit)[after:] - _wind(clean)[after:]).max() < 0.05


def _acceleration_glitch(af, monkeypatch=None):
    """(worst wind error one settling time after the glitch ends, the glitched run, the glitch's rows)
    for 0.5 s of -5 m/s^2 on every axis of the acceleration input, against the same flight without it."""
    model, clean_in = _simulated(af, hold_s=4.0)
    start = len(clean_in) // 3
    length = _rows(model, clean_in, start, 0.5)
    glitch = clean_in.copy()
    glitch[start:start + length, model.inputs.slice("acc_ned")] = -5.0
    clean, hit = reference.run(model, clean_in), reference.run(model, glitch)
    after = start + length + _rows(model, clean_in, start + length, model.settling_time_s)
    return np.abs(_wind(hit)[after:] - _wind(clean)[after:]).max(), hit, slice(start, start + length)


def _bias_airframes():
    from tests.families import FAMILIES, family_airframe

    # Every force-air family with an acceleration input and the velocity-aided bias estimate, and m300.
    changes = {"observer.acceleration": "ned", "observer.acceleration_bias_time": 20.0}
    return [load_airframe(M300)] + [family_airframe(f, **changes) for f in FAMILIES]


@pytest.mark.parametrize("index", range(4), ids=["m300", "polynomial", "drag-heading", "drag-body"])
def test_acceleration_glitch_is_rejected_and_the_estimate_recovers_within_one_settling_time(index, monkeypatch):
    """Issue #37, class 5: -5 m/s^2 on all axes for 0.5 s is inside every input bound. Before the acceleration
    check (model/biasgate.py) it entered the observer and the 20 s bias estimate: on m300 2.2 m/s of wind error
    one settling time after the glitch, up to 51 m/s on trusted rows. Now the glitch is IMPLAUSIBLE after a few
    samples and the estimate is back within 0.2 m/s of the clean flight's one settling time later."""
    from dobwind.model import biasgate

    af = _bias_airframes()[index]
    error, hit, rows = _acceleration_glitch(af)
    assert np.mean(hit.status[rows] & IMPLAUSIBLE != 0) > 0.8  # all but the few samples the average needs
    trusted = hit.status == 0
    assert np.all(np.linalg.norm(_wind(hit)[trusted], axis=1) <= P.MAX_WIND_MPS)
    assert error < 0.2
    # The check is what recovers it: switched off (a bound no disagreement reaches), the error stays.
    monkeypatch.setattr(biasgate, "FLOOR_MPS2", 1e5)
    assert _acceleration_glitch(af)[0] > max(0.15, 5 * error)


def test_the_acceleration_check_rejects_nothing_of_clean_flights():
    """The bound scales with the log's own disagreement: no sample of the simulated flights trips it."""
    for af in _bias_airframes():
        model, inputs = _simulated(af, hold_s=4.0)
        assert not np.any(reference.run(model, inputs).status & IMPLAUSIBLE)


def test_the_acceleration_check_cannot_lock_the_estimator_out():
    """A lasting change of the acceleration input (a new bias of 3 m/s^2 on every axis) is rejected at
    first, then accepted again: the check's bound grows with what it sees."""
    model, inputs = _simulated(load_airframe(M300), hold_s=30.0)
    start = len(inputs) // 4
    inputs[start:, model.inputs.slice("acc_ned")] += 3.0
    status = reference.run(model, inputs).status
    rejected = np.flatnonzero(status[start:] & IMPLAUSIBLE)
    assert rejected.size and rejected[-1] < _rows(model, inputs, start, 5.0)  # back within 5 s
    assert not np.any(status[start + rejected[-1] + 1:] & REJECTED_MASK)


@pytest.mark.parametrize("rate_hz", [50.0, 100.0, 400.0])
def test_a_glitch_raises_the_check_bound_by_a_rate_independent_closed_form(rate_hz):
    """Winsorised, each rejected sample adds slow * (bound - noise) = slow * ((S^2 - 1) noise + F^2): the noise
    after n rejections is (n0 + c) (1 + (S^2 - 1) slow)^n - c with c = F^2 / (S^2 - 1), slow = 1 - exp(-dt / T),
    so a glitch of 0.5 s multiplies the bound by about exp((S^2 - 1) 0.5 s / T) = 2.4 at any rate (the
    module's docstring). Unwinsorised, a 10 m/s^2 glitch would add its own square instead."""
    from dobwind.model import biasgate as B

    dt, n0, rows = 1.0 / rate_hz, 0.3, int(round(0.5 * rate_hz))
    check, noise = ca.DM([10.0, 10.0, 10.0]), ca.DM(n0)
    for _ in range(rows):
        out = B.check(ca.DM([10.0, 10.0, 10.0]), ca.DM(dt), check, noise, ca.DM(1.0))
        assert float(out["acc_status"]) == B.IMPLAUSIBLE_BIT
        check, noise = out["acc_check_new"], out["acc_noise_new"]
    s2, c = B.SIGMAS ** 2, B.FLOOR_MPS2 ** 2 / (B.SIGMAS ** 2 - 1.0)
    slow = -np.expm1(-dt / B.NOISE_TIME_S)
    assert float(noise) == pytest.approx((n0 + c) * (1.0 + (s2 - 1.0) * slow) ** rows - c, rel=1e-12)
    growth = (s2 * float(noise) + B.FLOOR_MPS2 ** 2) / (s2 * n0 + B.FLOOR_MPS2 ** 2)
    assert growth == pytest.approx(np.exp((s2 - 1.0) * 0.5 / B.NOISE_TIME_S), rel=0.02)
    assert 2.3 < growth < 2.5


def test_rpm_in_the_wrong_unit_is_rejected():
    """rpm logged x60 (Hz taken for rev/s): every sample IMPLAUSIBLE, the estimate never moves."""
    model, inputs = _simulated(load_airframe(M300))
    inputs[:, model.inputs.slice("rotor_rpm")] *= 60.0
    traj = reference.run(model, inputs)
    assert np.all(traj.status & IMPLAUSIBLE)
    initial = model.initial_state()
    never_moved = np.concatenate([initial[model.state.slice(f"last.{f.name}")] for f in model.outputs.fields])
    assert np.all(traj.outputs == never_moved)  # the initial output: zeros, the 1-sigma fields -1 (unknown)


# --- generate's self-test gate -----------------------------------------------------------------

def _variant(tmp_path, old: str, new: str):
    """m300 with ``old`` replaced by ``new`` (several pairs joined by " | ")."""
    text = M300.read_text()
    for before, after in zip(old.split(" | "), new.split(" | ")):
        assert before in text
        text = text.replace(before, after)
    path = tmp_path / "v.toml"
    path.write_text(text)
    return path


@pytest.mark.skipif(not HAS_CC, reason="no host C compiler")
@pytest.mark.parametrize("old, new", [
    ("max_tilt_deg = 60.0", "max_tilt_deg = 1.0"),       # the low edge of limits.max_tilt_deg
    # the high edge of mass (a 1,566 s settling time), with rotors that can lift it
    ("mass = 8.0  | [0.01315, 11.34, 207.0]", "mass = 10000.0  | [0.0, 11.34, 3e5]"),
    ("cutoffs = [0.2, 0.35, 0.5]", "cutoffs = [0.001, 0.001, 0.001]"),  # the low edge of filter.cutoffs
])
def test_edge_of_range_airframes_pass_generate_and_its_self_test(tmp_path, capsys, old, new):
    """Each failed its own self-test before (boundary rows too close to a float flip)."""
    assert main(["generate", str(_variant(tmp_path, old, new)), "-o", str(tmp_path / "c")]) == 0
    assert (tmp_path / "c" / "m300_wind.c").is_file()


def _fake_compiler(tmp_path, program: str):
    """A "compiler" that writes `program` as the output executable: a self-test that lies."""
    script = tmp_path / "fakecc"
    script.write_text("#!/bin/sh\nwhile [ $# -gt 0 ]; do if [ \"$1\" = -o ]; then out=$2; fi; shift; done\n"
                      f"printf '%s\\n' '#!/bin/sh' '{program}' > \"$out\"; chmod +x \"$out\"\n")
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return str(script)


@pytest.mark.parametrize("program, expected", [
    ("echo FAIL: 3 mismatches; exit 1", 1),   # C that disagrees with its golden vectors
    ("exit 0", 1),                             # exits 0 without its PASS line
    ("echo PASS: all steps; exit 0", 0),
])
def test_generate_writes_nothing_when_the_self_test_fails(tmp_path, capsys, monkeypatch, program, expected):
    monkeypatch.setenv("CC", _fake_compiler(tmp_path, program))
    out = tmp_path / "out"
    assert main(["generate", str(M300), "-o", str(out)]) == expected
    err = capsys.readouterr().err
    assert out.exists() == (expected == 0)
    if expected:
        assert len(err.strip().splitlines()) == 1 and "self-test" in err
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".dobwind-tmp")]


@pytest.mark.parametrize("program, expected", [
    ("echo FAIL: 3 mismatches; exit 1", 1),   # C that disagrees with its golden vectors
    ("exit 0", 1),                             # exits 0 without its PASS line
    ("echo PASS: all steps; exit 0", 0),
])
def test_check_runs_generate_s_self_test_gate(tmp_path, capsys, monkeypatch, program, expected):
    """check accepts exactly what generate accepts: the same self-test verdict, the same exit code; with
    --no-selftest the compiler is never called (a failing one then changes nothing)."""
    monkeypatch.setenv("CC", _fake_compiler(tmp_path, program))
    assert main(["check", str(M300)]) == expected
    assert main(["generate", str(M300), "-o", str(tmp_path / "out")]) == expected
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 * (expected != 0) and all("self-test" in line for line in err)
    assert main(["check", str(M300), "--no-selftest"]) == 0


def test_generate_without_a_compiler_warns_and_writes(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("CC", "no-such-compiler-dobwind")
    assert main(["generate", str(M300), "-o", str(tmp_path / "c")]) == 0
    assert "self-test was not run" in capsys.readouterr().err
    assert (tmp_path / "c" / "m300_wind_selftest.c").is_file()


def test_check_makes_generate_s_static_refusals(tmp_path, capsys):
    """A drag coefficient of 1e-30 squares to 1e-60 in the step: a float 0. check now refuses it too."""
    text = M300.read_text()
    start, end = text.index("[force_air.horizontal]"), text.index("[filter]")
    drag = '[force_air]\nmodel = "drag"\n\n[force_air.drag]\nl0 = 0.5\nq0 = 0.1\nlz = 1e-30\nqz = 0.2\n\n'
    path = tmp_path / "drag.toml"
    path.write_text(text[:start] + drag + text[end:])
    assert main(["check", str(path)]) == 2
    assert "would round to 0" in capsys.readouterr().err
    path.write_text(text[:start] + drag.replace("1e-30", "0.3") + text[end:])
    assert main(["check", str(path)]) == 0


# --- special files and stdout ------------------------------------------------------------------

@pytest.mark.parametrize("argv", [
    ["check", "{fifo}"], ["replay", str(M300), "{fifo}", "-o", "{tmp}/e.csv"], ["check", "/dev/zero"],
    ["simulate", "sweep", "--airframe", "/dev/zero", "-o", "{tmp}/s.csv"], ["verify", "{fifo}"],
])
def test_special_files_are_refused_by_type_without_blocking(tmp_path, capsys, argv):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    args = [a.format(fifo=fifo, tmp=tmp_path) for a in argv]
    assert main(args) == 2  # would hang forever (FIFO) or run out of memory (/dev/zero)
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "not a regular file" in err


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_stdout_on_a_full_device_is_one_line_exit_2():
    # --no-selftest: the two self-test builds (0.3 s) come before any output and are not what is tested
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "dobwind.cli", "check", str(M300), "--no-selftest"], stdout=full,
                              stderr=subprocess.PIPE, text=True, timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == ["dobwind check: stdout: No space left on device"]


def test_closed_stdout_is_one_line_exit_2():
    done = subprocess.run([sys.executable, "-m", "dobwind.cli", "check", str(M300), "--no-selftest"],
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, timeout=120, preexec_fn=lambda: os.close(1))
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "stdout" in done.stderr


def test_replay_of_a_log_in_absurd_units_never_trusts_an_absurd_wind(tmp_path, capsys):
    """The campaign's log classes through `dobwind replay`: rpm logged x60 over a third of the log and a
    0.5 s block of ground velocity at 1e6. Every trusted row of the estimate file stays below 50 m/s."""
    log = tmp_path / "log.csv"
    assert main(["simulate", "outdoor", "--hold", "2", "--rate", "100", "-o", str(log)]) == 0
    lines = log.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    columns = lines[header].split(",")
    rows = [line.split(",") for line in lines[header + 1:]]
    third = len(rows) // 3
    for row in rows[third:2 * third]:
        for name in ("rpm_1", "rpm_2", "rpm_3", "rpm_4"):
            row[columns.index(name)] = repr(float(row[columns.index(name)]) * 60)
    for row in rows[2 * third:2 * third + 50]:
        row[columns.index("vel_n")] = "1e6"
    log.write_text("\n".join(lines[:header + 1] + [",".join(r) for r in rows]) + "\n")
    out = tmp_path / "est.csv"
    assert main(["replay", str(M300), str(log), "-o", str(out)]) == 0
    est = np.genfromtxt(out, delimiter=",", names=True, comments="#")
    status = est["status"].astype(int)
    wind = np.stack([est["wind_n"], est["wind_e"], est["wind_d"]], axis=1)
    assert np.all(status[third:2 * third] & IMPLAUSIBLE)
    assert np.all(status[2 * third:2 * third + 50] & IMPLAUSIBLE)
    trusted = status == 0
    assert trusted.sum() > len(rows) // 4  # the sane parts are still estimated
    assert np.all(np.linalg.norm(wind[trusted], axis=1) <= P.MAX_WIND_MPS)


@pytest.mark.parametrize("airframe", ["m300", "nf_quad"])
def test_fuzzed_step_never_trusts_a_wind_beyond_the_bound_or_nan(airframe):
    """20,000 random (state, input) pairs, states spread to +-400 N / m/s: whatever the status says, a
    trusted sample (status 0) is finite and below 50 m/s (the campaign found 1,034,574 such calls)."""
    from dobwind.model.exercise import random_cases

    model = build_step(load_airframe(ROOT / "airframes" / f"{airframe}.toml"))
    states, inputs = random_cases(model, 20000, seed=37)
    states[:, :-2] *= np.random.default_rng(37).choice([1.0, 10.0, 100.0], size=(len(states), 1))
    states[:, model.state.slice("initialized")] = 1.0  # running and settled: only EXTRAPOLATED may flag
    states[:, model.state.slice("run_s")] = model.settling_time_s
    _, outputs, status = model.step.map(len(states))(states.T, inputs.T)
    outputs, status = np.asarray(outputs).T, np.asarray(status).ravel().astype(int)
    trusted = status == 0
    wind = outputs[trusted][:, model.outputs.slice("wind_ned")]
    assert trusted.sum() > 50  # trusted samples remain (nf_quad differences its velocity: most are IMPLAUSIBLE)
    assert np.all(np.isfinite(outputs[trusted])) and np.all(np.linalg.norm(wind, axis=1) <= P.MAX_WIND_MPS)


_ENVELOPE = "\n[envelope]\nforce_h_max = 15.0\nforce_z = [-20.0, 15.0]\nairflow_h_max = 40.0\n"


@pytest.mark.skipif(not HAS_CC, reason="no host C compiler")
@pytest.mark.parametrize("name", ["header: REJECTED_MASK loses NUMERIC (0x20)", "header: SETTLING_TIME_S x1.1",
                                  "envelope: force_h_max x1.01", "envelope: force_z low x1.01",
                                  "plausible: ground speed bound x1.1"])
def test_issue_37_surviving_mutants_fail_the_generated_self_test(tmp_path, name):
    """The header's macros and the envelope were checked by nothing; the plausibility bounds are new.
    Each mutant (tools/mutant_table.py) applied to fresh C must fail the self-test that generate runs."""
    from dobwind.codegen.generate import generate_code, write_files
    from tools.mutant_table import c_mutants
    from tools.mutants import apply_c_mutant
    from dobwind.model.airframe import parse_airframe
    from dobwind.generate.selftest_gate import run_selftest

    af = parse_airframe(M300.read_text() + _ENVELOPE, "m300+envelope")
    files = generate_code(af, "single").files
    (tmp_path / "clean").mkdir()
    (tmp_path / "mutant").mkdir()
    write_files(files, tmp_path / "clean")
    assert run_selftest(tmp_path / "clean", af.name, os.environ.get("CC", "cc")).ran  # the unmutated C passes
    mutant = next(m for m in c_mutants(af) if m.name == name)
    target = f"{af.name}_wind.h" if mutant.region == "header" else f"{af.name}_wind.c"
    write_files(dict(files, **{target: apply_c_mutant(files[target], mutant, "single", f"{af.name}_wind_")}),
                tmp_path / "mutant")
    with pytest.raises(CheckFailed, match="self-test"):
        run_selftest(tmp_path / "mutant", af.name, os.environ.get("CC", "cc"))


def test_verify_with_a_compiler_that_writes_nothing_is_one_line_exit_1(tmp_path, capsys, monkeypatch):
    """A "compiler" that exits 0 without output (issue #37: an IndexError, then a ctypes OSError)."""
    true = shutil.which("true")
    if true is None:
        pytest.skip("no true(1)")
    monkeypatch.setenv("CC", true)
    assert main(["verify", str(M300), "--precision", "single", "--steps", "200"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "wrote no" in err[0]


def test_a_csv_named_bin_is_refused_in_one_line(tmp_path, capsys):
    """pymavlink printed 1.9 million "bad header" lines for it."""
    log = tmp_path / "flight.bin"
    log.write_text("t,vel_n\n0,0\n" * 1000)
    assert main(["replay", str(M300), str(log), "-o", str(tmp_path / "e.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "0xA3 0x95" in err[0]


def test_failed_outputs_leave_no_temporaries(tmp_path, capsys):
    """generate -o LINK-TO-FOLDER writes into the linked folder; fit -o DIR/ is refused up front."""
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "link").symlink_to(real)
    assert main(["generate", str(M300), "-o", str(tmp_path / "link"), "--no-selftest"]) == 0
    assert (tmp_path / "link").is_symlink() and (real / "m300_wind.c").is_file()
    assert main(["fit", str(M300), str(M300), "-o", str(tmp_path / "new") + "/"]) == 2
    assert "ends with a slash" in capsys.readouterr().err
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".dobwind-tmp")]


def test_a_log_slower_than_max_dt_warns(tmp_path, capsys):
    log = tmp_path / "slow.csv"
    assert main(["simulate", "outdoor", "--hold", "2", "--rate", "5", "-o", str(log)]) == 0
    capsys.readouterr()
    assert main(["replay", str(M300), str(log)]) == 0
    err = capsys.readouterr().err
    assert "rejected as BAD_DT" in err and "a log slower than 1/limits.max_dt" in err and "10 Hz" in err


def test_analyze_writes_no_unstable_design(tmp_path, capsys):
    """Issue #37: `analyze m300.toml --bandwidth ' 5' -o new.toml` failed (the design is unstable at
    max_dt) and left new.toml modified. The same on nf_quad (50 Hz: half analyze's experiment)."""
    quad = ROOT / "airframes" / "nf_quad.toml"
    new = tmp_path / "new.toml"
    new.write_bytes(quad.read_bytes())
    assert main(["analyze", str(quad), "--bandwidth", " 5", "--freq", "0.1", "-o", str(new)]) == 1
    assert new.read_bytes() == quad.read_bytes()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not written" in err[0]
