"""ArduPilot DataFlash replay, on DataFlash files written here (tests/dataflash_writer.py): the replay
equals the replay of the equivalent CSV (the same float32 values on the same clock) within 1e-5."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.io.dataflash import follow_primary
from dobwind.io.logs import write_csv
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.model.status import STATUS_LANDED, STATUS_NO_DATA, accepted
from dobwind.replay.replay import replay, replay_autopilot
from dobwind.simulate.simulate import simulate
from tests.dataflash_writer import write_dataflash
from tests.helpers import M300, ROOT, airframe_dict

pytest.importorskip("pymavlink")

SHARED = ROOT.parent / "shared" / "data" / "ardupilot"
MESSAGES = {
    "XKF1": ("QBfffff", ["TimeUS", "C", "Yaw", "VN", "VE", "VD", "PD"]),
    "XKQ": ("QBffff", ["TimeUS", "C", "Q1", "Q2", "Q3", "Q4"]),
    "XKF2": ("QBff", ["TimeUS", "C", "VWN", "VWE"]),
    "IMU": ("QBfff", ["TimeUS", "I", "AccX", "AccY", "AccZ"]),
    "PSCN": ("Qf", ["TimeUS", "AN"]), "PSCE": ("Qf", ["TimeUS", "AE"]), "PSCD": ("Qf", ["TimeUS", "AD"]),
    "ESC": ("QBf", ["TimeUS", "Instance", "RPM"]),
    "CTUN": ("Qff", ["TimeUS", "ThO", "ThH"]),
    "ATT": ("Qf", ["TimeUS", "DesYaw"]),
    "EV": ("QB", ["TimeUS", "Id"]),
}
OLD_NAMES = {"XKF1": "NKF1", "XKQ": "NKQ1", "XKF2": "NKF2"}
HOVER = 0.4


def f32(x):
    return np.asarray(x, dtype=np.float32).astype(float)


def _flight(rate=50.0):
    """On a uniform clock (replay resamples onto one); tests comparing row for row replay at ``rate``."""
    af = load_airframe(M300)
    cols = simulate(af, "tunnel", seed=3, hold_s=4.0, rate_hz=rate)
    return af, {**cols, "t": np.arange(len(cols["t"])) / rate}


def _rows(af, cols, *, landed_until=None, drop=(), old=False, esc_zero=None):
    """One of every message per sample, plus a second EKF core / IMU with nonsense the reader must skip."""
    rows = [("EV", {"TimeUS": 1_000_000, "Id": 10})]
    if landed_until is None:
        rows.append(("EV", {"TimeUS": 1_000_000, "Id": 28}))
    mg = af.mass_kg * af.gravity_mps2
    for k, t in enumerate(cols["t"]):
        us = 1_000_000 + int(round(t * 1e6))
        if landed_until is not None and k > 0 and cols["t"][k - 1] < landed_until <= t:
            rows.append(("EV", {"TimeUS": us, "Id": 28}))
        for core, junk in ((0, 1.0), (1, 50.0)):
            rows.append(("XKF1", {"TimeUS": us, "C": core, "Yaw": 0.0, "VN": cols["vel_n"][k] * junk,
                                  "VE": cols["vel_e"][k], "VD": cols["vel_d"][k]}))
            rows.append(("XKQ", {"TimeUS": us, "C": core, **{f"Q{i + 1}": cols[f"q_{c}"][k] for i, c in enumerate("wxyz")}}))
            rows.append(("XKF2", {"TimeUS": us, "C": core, "VWN": cols["wind_n"][k] * junk, "VWE": cols["wind_e"][k]}))
            rows.append(("IMU", {"TimeUS": us, "I": core, "AccX": junk, "AccY": 0.0, "AccZ": -9.8}))
        for name, field, key in (("PSCN", "AN", "acc_n"), ("PSCE", "AE", "acc_e"), ("PSCD", "AD", "acc_d")):
            rows.append((name, {"TimeUS": us, field: cols[key][k]}))
        for i in range(4):
            rpm = 0.0 if esc_zero is not None and i == 1 and esc_zero[0] < t < esc_zero[1] else cols[f"rpm_{i + 1}"][k]
            rows.append(("ESC", {"TimeUS": us, "Instance": i, "RPM": rpm}))
        rows.append(("CTUN", {"TimeUS": us, "ThO": cols["thrust"][k] / mg * HOVER, "ThH": HOVER}))
        rows.append(("ATT", {"TimeUS": us, "DesYaw": np.degrees(cols["yaw_ref"][k])}))
    rows = [r for r in rows if r[0] not in drop]
    if old:  # EKF2 names have no core field: only core 0 is written under them
        rows = [(OLD_NAMES.get(n, n), v) for n, v in rows if n not in OLD_NAMES or v["C"] == 0]
    return rows


def _bin(path, af, cols, **kw):
    messages = dict(MESSAGES)
    if kw.get("old"):
        for new, oldname in OLD_NAMES.items():
            fmt, columns = messages.pop(new)
            messages[oldname] = (fmt.replace("B", "", 1), [c for c in columns if c != "C"])
    return write_dataflash(path, messages, _rows(af, cols, **kw))


def _equivalent_csv(path, af, cols):
    """What the DataFlash file holds, as a CSV: float32 values, the microsecond clock, normalised q."""
    us = 1_000_000 + np.round(cols["t"] * 1e6)
    q = np.column_stack([f32(cols[f"q_{c}"]) for c in "wxyz"])
    q /= np.linalg.norm(q, axis=1)[:, None]
    out = {"t": us * 1e-6 - us[0] * 1e-6, "vel_n": f32(cols["vel_n"]), "vel_e": f32(cols["vel_e"]), "vel_d": f32(cols["vel_d"]),
           "acc_n": f32(cols["acc_n"]), "acc_e": f32(cols["acc_e"]), "acc_d": f32(cols["acc_d"]),
           **{f"q_{c}": q[:, i] for i, c in enumerate("wxyz")},
           **{f"rpm_{i}": f32(cols[f"rpm_{i}"]) for i in range(1, 5)},
           "yaw_ref": np.radians(f32(np.degrees(cols["yaw_ref"])))}
    names = list(out)
    write_csv(path, names, np.column_stack([out[n] for n in names]), ["%.17g"] * len(names))
    return path


@pytest.mark.parametrize("old", [False, True])
def test_dataflash_replay_equals_the_equivalent_csv(tmp_path, old):
    af, cols = _flight()
    model, flight, traj = replay_autopilot(af, str(_bin(tmp_path / "f.bin", af, cols, old=old)), rate_hz=50.0)
    _, log, ref = replay(af, str(_equivalent_csv(tmp_path / "f.csv", af, cols)))
    assert flight.log.rows == log.rows and np.all(accepted(traj.status))
    np.testing.assert_array_equal(traj.status, ref.status)
    assert np.max(np.abs(traj.outputs - ref.outputs)) <= 1e-5
    assert flight.autopilot_wind[0] == ("ArduPilot NKF2" if old else "ArduPilot XKF2")
    # Core 0's wind, not core 1's (fifty times larger north wind).
    np.testing.assert_allclose(flight.autopilot_wind[2][:, 0], f32(cols["wind_n"]), atol=1e-6)


def _switch_primary(rows, at_us: int, with_xkf4: bool):
    """From at_us on, core 1 carries the good data and core 0 the nonsense (the cores' labels swap),
    and XKF4.PI on both cores says which is primary, as EKF3 logs a lane switch."""
    out = []
    for name, v in rows:
        if name in ("XKF1", "XKQ", "XKF2") and v["TimeUS"] >= at_us:
            v = dict(v, C=1 - v["C"])
        out.append((name, v))
        if with_xkf4 and name == "XKF1" and v["C"] == 0:
            for core in (0, 1):
                out.append(("XKF4", {"TimeUS": v["TimeUS"], "C": core, "PI": int(v["TimeUS"] >= at_us)}))
    return out


def test_the_primary_core_is_followed_across_a_lane_switch(tmp_path):
    af, cols = _flight()
    messages = dict(MESSAGES, XKF4=("QBB", ["TimeUS", "C", "PI"]))
    rows = _switch_primary(_rows(af, cols), 9_000_000, with_xkf4=True)
    model, flight, traj = replay_autopilot(af, str(write_dataflash(tmp_path / "s.bin", messages, rows)), rate_hz=50.0)
    _, log, ref = replay(af, str(_equivalent_csv(tmp_path / "s.csv", af, cols)))
    assert flight.log.rows == log.rows and np.all(accepted(traj.status))
    assert np.max(np.abs(traj.outputs - ref.outputs)) <= 1e-5
    np.testing.assert_allclose(flight.autopilot_wind[2][:, 0], f32(cols["wind_n"]), atol=1e-6)
    assert any("1 switch(es) among cores 0, 1" in n for n in flight.notes)
    # The same log without XKF4 reads core 0 throughout: after the switch that is the nonsense core.
    blind = _switch_primary(_rows(af, cols), 9_000_000, with_xkf4=False)
    _, flight0, _ = replay_autopilot(af, str(write_dataflash(tmp_path / "b.bin", MESSAGES, blind)), rate_hz=50.0)
    late = flight0.log.time_s > 8.5
    assert np.max(np.abs(flight0.log.columns["vel_n"][late] - f32(cols["vel_n"])[late])) > 1.0


def _cores(times_us) -> list[dict]:
    """XKF1 rows of cores 0 and 1 at each stamp, VN naming the row (core * 1000 + stamp in ms)."""
    return [{"TimeUS": t, "C": c, "VN": float(c * 1000 + t // 1000)} for t in times_us for c in (0, 1)]


def _kept(msgs: dict) -> list[float]:
    return [r["VN"] for r in follow_primary(msgs, [])["XKF1"]]


def test_the_primary_core_is_chosen_by_time_whatever_the_log_order():
    """Markers and rows whose stamps go backwards in log order (XKF4 at 30 ms logged before those at 10
    and 20 ms, an XKF1 at 5 ms after the one at 25 ms): each row takes the PI of the last marker at or
    before its own stamp (the first marker's before any), as in time order."""
    marks = [{"TimeUS": t, "C": 0, "PI": pi} for t, pi in ((30_000, 1), (10_000, 0), (20_000, 0))]
    rows = _cores([15_000, 25_000, 5_000, 35_000, 30_000])
    # before 30 ms core 0 (VN = stamp in ms); from 30 ms core 1 (1000 + stamp); log order kept
    assert _kept({"XKF4": marks, "XKF1": rows}) == [15.0, 25.0, 5.0, 1035.0, 1030.0]


def test_the_primary_core_is_followed_across_a_stamp_wrap():
    """Stamps that wrap (TimeMS is a uint32: 2**32 ms, 49.7 days): the rows before the wrap, at the
    largest stamps, take the markers before the wrap, and those after it the markers after it, each the
    last at or before its stamp (markers of either stretch never reach into the other)."""
    wrap = 2**32 * 1000  # TimeUS = 1000 TimeMS, the last stamp before the wrap
    marks = [{"TimeUS": t, "C": 0, "PI": pi} for t, pi in ((wrap - 30_000, 0), (wrap - 15_000, 1), (0, 1), (20_000, 0))]
    rows = _cores([wrap - 25_000, wrap - 10_000, 10_000, 25_000])
    assert _kept({"XKF4": marks, "XKF1": rows}) == [float((wrap - 25_000) // 1000), 1000.0 + (wrap - 10_000) // 1000,
                                                     1010.0, 25.0]


def test_rows_without_a_stamp_are_left_out_of_the_primary_core_not_a_traceback():
    """A marker or a per-core row with neither TimeUS nor TimeMS (load_messages turns TimeMS into TimeUS)
    cannot be placed in time: it is skipped, as pick_stream skips it, never a KeyError."""
    marks = [{"TimeUS": 10_000, "C": 0, "PI": 0}, {"C": 0, "PI": 1}, {"TimeUS": 20_000, "C": 0, "PI": 1}]
    rows = _cores([15_000, 25_000]) + [{"C": 1, "VN": -1.0}]
    assert _kept({"XKF4": marks, "XKF1": rows}) == [15.0, 1025.0]


def test_a_marker_logged_without_a_stamp_reads_core_0(tmp_path):
    """XKF4 declared with no time field at all (a layout this reader does not know): its PI cannot be
    placed, so the log is read as one without XKF4 (core 0 throughout, no primary-core note), not by
    its PI 1 (core 1 holds fifty times the north velocity)."""
    af, cols = _flight(rate=20.0)
    rows = [(n, {"C": v["C"], "PI": 1} if n == "XKF4" else v)
            for n, v in _switch_primary(_rows(af, cols), 10**12, with_xkf4=True)]
    _, flight, _ = replay_autopilot(af, str(write_dataflash(tmp_path / "n.bin", dict(MESSAGES, XKF4=("BB", ["C", "PI"])),
                                                            rows)), rate_hz=20.0)
    assert not any("primary core" in n for n in flight.notes)
    np.testing.assert_allclose(flight.log.columns["vel_n"], f32(cols["vel_n"]), atol=1e-5)


def test_a_marker_stamped_in_milliseconds_is_followed(tmp_path):
    """XKF4 logged with TimeMS only (older firmware's stamp): read as TimeUS = 1000 TimeMS by
    load_messages, the lane switch is followed as with microsecond stamps."""
    af, cols = _flight()
    rows = [(n, {"TimeMS": v["TimeUS"] // 1000, "C": v["C"], "PI": v["PI"]} if n == "XKF4" else v)
            for n, v in _switch_primary(_rows(af, cols), 9_000_000, with_xkf4=True)]
    messages = dict(MESSAGES, XKF4=("IBB", ["TimeMS", "C", "PI"]))
    _, flight, traj = replay_autopilot(af, str(write_dataflash(tmp_path / "ms.bin", messages, rows)), rate_hz=50.0)
    _, _, ref = replay(af, str(_equivalent_csv(tmp_path / "s.csv", af, cols)))
    assert np.max(np.abs(traj.outputs - ref.outputs)) <= 1e-5
    assert any("1 switch(es) among cores 0, 1" in n for n in flight.notes)


def test_collective_thrust_from_ctun_and_the_landing_events(tmp_path):
    af = parse_airframe(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0, name="coll")), "<c>")
    _, cols = _flight()
    model, flight, traj = replay_autopilot(af, str(_bin(tmp_path / "c.bin", af, cols, landed_until=3.0)), rate_hz=50.0)
    t = flight.log.time_s
    live = t > 3.1
    np.testing.assert_allclose(flight.log.columns["thrust"][live], cols["thrust"][live], rtol=1e-5)
    assert np.all(traj.status[t < 2.95] == STATUS_LANDED) and np.all(accepted(traj.status[live]))


def test_esc_at_zero_rpm_while_airborne_is_no_data_named(tmp_path):
    af, cols = _flight()
    _, flight, traj = replay_autopilot(af, str(_bin(tmp_path / "z.bin", af, cols, esc_zero=(8.0, 9.0))))
    t = flight.log.time_s
    assert np.all(traj.status[(t > 8.05) & (t < 8.95)] == STATUS_NO_DATA)
    assert np.all(accepted(traj.status[(t < 7.95) | (t > 9.05)]))
    assert any("ESC 2 (0 rpm)" in n for n in flight.notes)


def test_a_message_gap_is_no_data_and_the_note_names_the_message(tmp_path):
    """Core 0's XKQ silent for 0.5 s (core 1 still talking): those rows are NO_DATA, the rest are fed,
    and the note says it was XKQ."""
    af, cols = _flight()
    rows = [(n, v) for n, v in _rows(af, cols)
            if not (n == "XKQ" and v["C"] == 0 and 11_000_000 < v["TimeUS"] < 11_500_000)]
    _, flight, traj = replay_autopilot(af, str(write_dataflash(tmp_path / "g.bin", MESSAGES, rows)), rate_hz=100.0)
    t = flight.log.time_s
    assert np.all(traj.status[(t > 10.02) & (t < 10.48)] == STATUS_NO_DATA)
    assert np.all(accepted(traj.status[(t > 1.0) & (t < 9.98)])) and np.all(accepted(traj.status[t > 10.52]))
    note = next(n for n in flight.notes if "message gap" in n)
    assert note.endswith(f"by message: XKQ {int(np.sum(traj.status == STATUS_NO_DATA))}): status NO_DATA"), note


@pytest.mark.parametrize("drop, named", [(("XKF1",), "XKF1"), (("XKQ",), "XKQ"), (("ESC",), "ESC Instance 0")])
def test_a_missing_message_exits_2_naming_it(tmp_path, capsys, drop, named):
    af, cols = _flight(rate=20.0)
    path = _bin(tmp_path / "m.bin", af, cols, drop=drop)
    assert main(["replay", str(M300), str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and named in err and str(path) in err


def test_garbage_exits_2_without_traceback(tmp_path, capsys):
    path = tmp_path / "bad.bin"
    path.write_bytes(bytes(range(256)) * 40)
    assert main(["replay", str(M300), str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and "Traceback" not in err


def test_fit_on_dataflash_equals_fit_on_the_equivalent_csv(tmp_path, capsys):
    # A 25 Hz observer on a 25 Hz log with a uniform clock: the DataFlash replay resamples onto the
    # observer's rate, and row-for-row equality with the CSV needs the same instants.
    m300_25 = tmp_path / "m300_25.toml"
    m300_25.write_text(M300.read_text().replace("sample_time = 0.01", "sample_time = 0.04", 1))
    af = load_airframe(m300_25)
    cols = simulate(af, "still-air", seed=4, hold_s=2.0, rate_hz=25.0)
    cols = {**cols, "t": np.arange(len(cols["t"])) / 25.0, "wind_n": np.zeros_like(cols["t"]),
            "wind_e": np.zeros_like(cols["t"])}
    fitted = []
    for log in (_bin(tmp_path / "still.bin", af, cols), _equivalent_csv(tmp_path / "still.csv", af, cols)):
        out = tmp_path / f"{log.suffix[1:]}.toml"
        code = main(["fit", str(m300_25), str(log), "--still-air", "-o", str(out), "--model", "polynomial",
                     "--terms", "airframe", "--dynamic", "--json", "--force"])  # equality, not quality
        assert code == 0, capsys.readouterr().err
        fitted.append(load_airframe(out))
    capsys.readouterr()
    a, b = fitted
    np.testing.assert_allclose(a.horizontal.coefficients, b.horizontal.coefficients, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(a.thrust.scale, b.thrust.scale, rtol=1e-5)
    assert main(["fit", str(M300), str(tmp_path / "still.bin"), "-o", str(tmp_path / "x.toml")]) == 2
    assert "--still-air" in capsys.readouterr().err


@pytest.mark.parametrize("name, present, absent, refusal", [
    ("arducopter-4.6.2-prearm.bin", ("XKF1", "XKQ", "XKF2", "IMU", "CTUN", "ATT"), ("ESC", "NKF1"), "ESC Instance 0"),
    ("arduplane-ekf2-truncated.bin", ("NKF1", "NKQ1", "NKF2", "IMU", "ATT"), ("XKF1", "XKQ", "ESC"),
     "vehicle: ArduPlane V3.8.2-dev with Q_ENABLE 0: a fixed-wing plane")])
def test_real_logs_parse_and_name_their_messages(name, present, absent, refusal, capsys):
    """Optional (needs ../shared/data): the real logs' message sets, and a clean refusal for rpm (the
    plane's, before any message, for being a plane)."""
    path = SHARED / name
    if not path.exists():
        pytest.skip(f"{name} is not beside this checkout")
    from dobwind.io.dataflash import messages_found

    found = messages_found(str(path))
    assert all(found[m] > 0 for m in present) and all(found[m] == 0 for m in absent)
    assert main(["replay", str(M300), str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and refusal in err, err


def test_a_damaged_log_replays_quietly_at_the_descriptor_level(tmp_path, capfd):
    """4 kB of garbage inside a valid log: pymavlink printed a "bad header" line per skipped byte, partly
    from compiled code straight to descriptor 2 (4,132 lines here before dobwind/io/quietfd.py), which
    capsys does not see. capfd reads descriptors 1 and 2 themselves (a child process is not needed for
    that, and costs a second of imports): the replay succeeds, stdout holds the summary only, and stderr
    no pymavlink line."""
    af, cols = _flight()
    path = _bin(tmp_path / "m.bin", af, cols)
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 4096] = bytes((7 * k + 13) % 256 for k in range(4096))
    path.write_bytes(bytes(data))
    capfd.readouterr()  # what the log's writing printed, if anything
    code = main(["replay", str(M300), str(path), "-o", str(tmp_path / "e.csv")])
    done = capfd.readouterr()
    assert code == 0, done.err
    assert "bad header" not in done.out + done.err
    assert len(done.err.splitlines()) <= 3  # warnings of dobwind's own (the gap the garbage left), if any


def test_a_truncated_dataflash_log_replays_the_readable_part_with_a_warning(tmp_path, capsys):
    """A log cut inside a message (a power cut, an interrupted copy) was replayed without a word, where a
    cut ULog is warned about; the whole log, which ends on a message boundary, says nothing."""
    import json

    from dobwind.io.dataflash import truncation

    af, cols = _flight()
    whole = _bin(tmp_path / "whole.bin", af, cols)
    path = tmp_path / "cut.bin"
    path.write_bytes(whole.read_bytes()[: len(whole.read_bytes()) * 2 // 3 + 7])
    assert truncation(str(whole)) is None and "at byte" in (truncation(str(path)) or "")
    assert main(["replay", str(M300), str(path), "--json"]) == 0
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and f"{path}: truncated: the file ends inside a message" in captured.err
    summary = json.loads(captured.out)
    assert summary["warnings"] and 0.5 * cols["t"][-1] < summary["duration_s"] < 0.75 * cols["t"][-1]
    assert main(["replay", str(M300), str(whole)]) == 0 and capsys.readouterr().err == ""
    garbled = bytearray(whole.read_bytes())
    garbled[len(garbled) // 2: len(garbled) // 2 + 64] = bytes(64)   # corrupt mid-file: not a cut end
    assert truncation(str(_write_bytes(tmp_path / "garbled.bin", bytes(garbled)))) is None


def _write_bytes(path, data: bytes):
    path.write_bytes(data)
    return path


def test_a_format_shorter_than_its_header_ends_the_walk(tmp_path):
    """truncation() stepped by each message's declared length: a corrupt FMT declaring 0 bytes made it
    step by nothing, for ever (in a child here, so that the old hang fails the test instead of the run).
    Such a file cannot be walked: not a cut end."""
    import struct
    import subprocess
    import sys

    fmt_of_fmt = b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", 128, 89, b"FMT", b"BBnNZ", b"Type,Length,Name,Format,Columns")
    zero = b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", 130, 0, b"BAD", b"", b"")
    path = tmp_path / "zero.bin"
    path.write_bytes(fmt_of_fmt + zero + b"\xa3\x95\x82" + bytes(10))
    code = f"from dobwind.io.dataflash import truncation; print(truncation({str(path)!r}))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0 and done.stdout.strip() == "None", done.stderr


def test_a_format_shorter_than_its_header_is_refused_before_dfreader(tmp_path):
    """pymavlink's DFReader stalls for ever on a message whose FMT declares fewer bytes than its 3-byte header
    (it steps by that length). Such a log gets one line and exit 2 from every command that reads it (in a
    child with a timeout, so that a stall fails the test instead of hanging the run)."""
    import struct
    import subprocess
    import sys

    fmt_of_fmt = b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", 128, 89, b"FMT", b"BBnNZ", b"Type,Length,Name,Format,Columns")
    zero = b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", 130, 0, b"BAD", b"", b"")
    path = tmp_path / "zero.bin"
    path.write_bytes(fmt_of_fmt + bytes(7) + zero + b"\xa3\x95\x82" + bytes(10))   # garbage between: resynced
    done = subprocess.run([sys.executable, "-m", "dobwind.cli", "inspect", str(path)], capture_output=True,
                          text=True, timeout=60, cwd=ROOT)
    err = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(err) == 1, done.stderr
    assert str(path) in err[0] and "type 130" in err[0] and "declared 0 bytes" in err[0]


def test_a_log_on_the_ground_throughout_says_it_was_never_airborne(tmp_path, capsys):
    """A pre-arm or bench log: every row LANDED, nothing estimated. replay says so in one warning line (and in
    --json's warnings); a log that flew says nothing of the kind."""
    import json

    af, cols = _flight()
    rows = _rows(af, cols, landed_until=cols["t"][-1] + 1.0)   # no NOT_LANDED event ...
    rows.insert(0, ("EV", {"TimeUS": 1_000_000, "Id": 18}))     # ... after a LAND_COMPLETE at the start
    ground = write_dataflash(tmp_path / "ground.bin", dict(MESSAGES), rows)
    assert main(["replay", str(M300), str(ground), "--json"]) == 0
    captured = capsys.readouterr()
    assert f"{ground}: never airborne in its" in captured.err and captured.err.count("never airborne") == 1
    assert any("never airborne" in w for w in json.loads(captured.out)["warnings"])
    flew = _bin(tmp_path / "flew.bin", af, cols, landed_until=1.0)
    assert main(["replay", str(M300), str(flew)]) == 0
    assert "never airborne" not in capsys.readouterr().err


def test_arducopters_density_step_in_the_throttle_is_undone(tmp_path):
    """ArduCopter 4.1 logs the throttle divided by a density ratio that is 1 until the baro altitude first
    moves 25 m (dobwind/io/densitystep.py). A climb from 0 to 40 m through the flight, ThO logged under that
    rule: the thrust read back is the flight's own (float32), where the logged ThO / ThH reads 10 % low
    after the step; the note names the step."""
    from dobwind.io.densitystep import applied_ratio

    af = parse_airframe(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0, name="coll")), "<c>")
    _, cols = _flight()
    t = cols["t"]
    alt = 40.0 * t / t[-1]
    baro = {"Alt": alt, "Press": 94_500.0 - 11.0 * alt, "GndTemp": np.full(len(t), 25.0)}
    ratio = applied_ratio(baro["Alt"], baro["Press"], baro["GndTemp"])
    rows = []
    for name, v in _rows(af, cols):
        if name == "CTUN":
            k = int(round((v["TimeUS"] - 1_000_000) * 1e-6 * 50.0))
            v = dict(v, ThO=v["ThO"] * ratio[k])
            rows.append(("BARO", {"TimeUS": v["TimeUS"], "I": 0, **{f: baro[f][k] for f in baro}}))
        rows.append((name, v))
    messages = dict(MESSAGES, BARO=("QBfff", ["TimeUS", "I", "Alt", "Press", "GndTemp"]))
    path = str(write_dataflash(tmp_path / "d.bin", messages, rows))
    _, flight, _ = replay_autopilot(af, path, rate_hz=50.0)
    after = alt >= 25.0
    assert 0.89 < ratio[after][0] < 0.91 and after.sum() > 100
    np.testing.assert_allclose(flight.log.columns["thrust"], cols["thrust"], rtol=1e-5)
    assert any("ArduCopter's air-density compensation" in n for n in flight.notes), flight.notes
    from dobwind.inspect.anylog import inspect_log

    said = [n for n in inspect_log(path).notes if "air-density compensation" in n]  # inspect says it too
    assert len(said) == 1 and f"to {ratio[after][0]:.3f} at" in said[0], said



def test_replay_and_inspect_walk_a_dataflash_log_once(tmp_path, monkeypatch):
    """load_messages walked the file's messages (dfwalk), then damage() and truncation() read and walked it
    again for their notes (60 ms of a 3.5 MB log each time). The first walk now gives the notes: one read
    of the file for replay and for inspect, and the same notes as the separate calls give, on a whole, a cut
    and a damaged log."""
    import dobwind.io.dataflash as df
    from dobwind.inspect.inspect_dataflash import inspect_dataflash
    from tests.test_logfuzz import _retyped

    af, cols = _flight()
    whole = _bin(tmp_path / "whole.bin", af, cols)
    cut = _write_bytes(tmp_path / "cut.bin", whole.read_bytes()[: len(whole.read_bytes()) * 2 // 3 + 7])
    damaged = _write_bytes(tmp_path / "damaged.bin", _retyped(whole.read_bytes(), 0.25, 7)[0])
    for path, truncated, hurt in ((whole, False, False), (cut, True, False), (damaged, False, True)):
        _, said = df.read_messages(str(path))
        assert said == df.FileNotes(df.truncation(str(path)), df.damage(str(path)))
        assert (said.truncated is not None, said.damaged is not None) == (truncated, hurt)
    reads = []
    real = df._read
    monkeypatch.setattr(df, "_read", lambda path: reads.append(path) or real(path))
    flight = df.read_dataflash(str(cut), af, rate_hz=50.0)
    assert reads == [str(cut)] and any("truncated" in w for w in flight.warnings)
    reads.clear()
    summary = inspect_dataflash(str(damaged))
    assert reads == [str(damaged)] and any("damaged" in n for n in summary.notes)
