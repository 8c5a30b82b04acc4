"""Regressions found by mutating real-world-shaped logs (truncations, flipped bytes, altered formats,
timestamps out of order) and running every command that takes a log on them: each input is made here
(tests/dataflash_writer.py, tests/ulog_writer.py or bytes written in the test), and each test checks the
contract of ../shared/spec/INTERFACES.md: one stderr line naming the file, exit 2 or 1, no traceback."""
from __future__ import annotations

import struct
import warnings
from pathlib import Path

import numpy as np
import pytest

from dobwind.cli.app import main
from tests import atmos_logs
from tests.helpers import M300


def _garbled(path: Path) -> Path:
    """4 kB of bytes that are no DataFlash message in the middle of ``path``: DFReader skips them byte by
    byte, printing a "bad header" line for each, partly from compiled code to descriptor 2."""
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 4096] = bytes((7 * k + 13) % 256 for k in range(4096))
    path.write_bytes(bytes(data))
    return path


def test_profile_of_a_damaged_dataflash_log_prints_no_reader_chatter(tmp_path, capfd):
    """The position track (dobwind/io/position.py) read DataFlash with Python's redirect_stdout only:
    pymavlink's per-byte "bad header" lines reached stderr, 157 of them for a 4-byte flip in a real
    ArduCopter log. capfd reads descriptors 1 and 2 themselves."""
    _, cols = atmos_logs.flight(hold_s=1.0)
    log = _garbled(atmos_logs.write_log(tmp_path / "f.bin", cols))
    capfd.readouterr()
    code = main(["profile", str(M300), str(log), "-o", str(tmp_path / "p.csv"), "--allow", "uncalibrated"])
    done = capfd.readouterr()
    assert "bad header" not in done.out + done.err
    assert code == 0 or len(done.err.strip().splitlines()) == 1, done.err


def _ulog_messages(blob: bytes) -> list[tuple[int, int, str]]:
    """(offset, payload size, type) of every ULog message after the 16-byte file header."""
    out, pos = [], 16
    while pos + 3 <= len(blob):
        size, kind = struct.unpack_from("<HB", blob, pos)
        out.append((pos, size, chr(kind)))
        pos += 3 + size
    return out


def _written_out_of_order(blob: bytes, msg_id: int, rows: range) -> bytes:
    """``blob`` with the data messages of ``msg_id`` swapped pairwise over ``rows``: each keeps its own
    timestamp, so the file holds the same samples, written out of time order (a logger flushing a
    buffer late, or two logs spliced)."""
    data = bytearray(blob)
    mine = [(o, s) for o, s, kind in _ulog_messages(blob)
            if kind == "D" and struct.unpack_from("<H", blob, o + 3)[0] == msg_id]
    for k in rows[::2]:
        (o1, s1), (o2, s2) = mine[k], mine[k + 1]
        assert s1 == s2  # one topic, one size: the two messages trade places, the rest stays put
        data[o1:o1 + 3 + s1], data[o2:o2 + 3 + s2] = data[o2:o2 + 3 + s2], data[o1:o1 + 3 + s1]
    return bytes(data)


def test_a_ulog_topic_written_out_of_time_order_replays_as_the_ordered_one(tmp_path):
    """The ULog reader interpolated each topic in file order: np.interp and searchsorted assume times that
    increase, so 50 pairs of attitude rows written swapped moved the wind estimate by up to 360 (its
    direction) with no note. The same samples in either order are the same flight."""
    from dobwind.replay.replay import replay_ulog
    from tests.test_ulog import _flight, _ulog

    af, cols = _flight()
    ordered = _ulog(tmp_path / "ordered.ulg", cols)
    swapped = tmp_path / "swapped.ulg"
    swapped.write_bytes(_written_out_of_order(ordered.read_bytes(), 1, range(500, 600)))  # 1: vehicle_attitude
    assert swapped.read_bytes() != ordered.read_bytes()
    _, _, want = replay_ulog(af, str(ordered))
    _, _, got = replay_ulog(af, str(swapped))
    np.testing.assert_array_equal(got.status, want.status)
    np.testing.assert_array_equal(got.outputs, want.outputs)


def _retyped(blob: bytes, at_share: float, new_type: int) -> tuple[bytes, int]:
    """``blob`` with the type byte of the first message at or after ``at_share`` of the file set to
    ``new_type``, which no FMT declares (a damaged byte on the card), and that message's offset. Walks the
    messages with the lengths the FMT messages declare."""
    lengths, pos = {128: 89}, 0
    while pos < len(blob):
        kind = blob[pos + 2]
        if kind == 128:
            lengths[blob[pos + 3]] = blob[pos + 4]
        elif pos >= at_share * len(blob):
            return blob[:pos + 2] + bytes([new_type]) + blob[pos + 3:], pos
        pos += lengths[kind]
    raise AssertionError("no message there")


def test_a_dataflash_message_of_an_undeclared_type_does_not_end_the_log_there(tmp_path):
    """pymavlink's DFReader indexes a log until the first message whose type no FMT declares, and reads
    nothing after it, silently: one damaged type byte a quarter into a 3.5 MB ArduCopter log left 4.5 s of
    its 113 s (found by the logfuzz campaign's bit flips). That header is now skipped as a bad one is (the
    reader resynchronises on the next message), and a note names its byte: the rest of the flight is read."""
    from dobwind.replay.replay import replay_autopilot
    from tests.test_dataflash import _bin, _flight

    af, cols = _flight()
    whole = _bin(tmp_path / "whole.bin", af, cols)
    damaged, at = _retyped(whole.read_bytes(), 0.25, 7)
    path = tmp_path / "damaged.bin"
    path.write_bytes(damaged)
    _, want, _ = replay_autopilot(af, str(whole), rate_hz=50.0)
    _, got, traj = replay_autopilot(af, str(path), rate_hz=50.0)
    np.testing.assert_array_equal(got.log.time_s, want.log.time_s)
    assert any(f"type 7 at byte {at:,}" in said for said in got.warnings), got.warnings


def test_a_huge_finite_quaternion_cell_prints_no_numpy_warning(tmp_path):
    """A damaged cell (q_z = 1e308, finite, so the reader takes it) overflowed in the heading's yaw
    (model/attitude.py) and numpy printed "RuntimeWarning: overflow encountered in multiply" and the
    source line on stderr of a replay that succeeded. The step rejects that row by its quaternion norm;
    stderr says nothing of numpy's."""
    from dobwind.io.logs import write_csv
    from dobwind.simulate.simulate import column_order, simulate
    from dobwind.model.airframe import load_airframe

    af = load_airframe(M300)
    cols = simulate(af, "tunnel", seed=2, hold_s=1.0, rate_hz=50.0)
    cols["q_z"] = cols["q_z"].copy()
    cols["q_z"][100:103] = 1e308
    names = [n for n in column_order(cols) if n != "yaw_ref"]  # the heading from q: its yaw
    log = tmp_path / "huge.csv"
    write_csv(log, names, np.column_stack([cols[n] for n in names]), ["%.17g"] * len(names))
    with warnings.catch_warnings(record=True) as caught:  # what Python would print on stderr
        warnings.simplefilter("always")
        assert main(["replay", str(M300), str(log), "-o", str(tmp_path / "e.csv")]) == 0
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in caught]


@pytest.mark.parametrize("name", ["CTUN", "EV", "ESC", "PARM"])
def test_a_dataflash_message_logged_without_timeus_is_no_traceback(tmp_path, capsys, name):
    """A message whose FMT names no TimeUS column (a damaged FMT's column list; the campaign emptied
    CTUN's) came back from DFReader without that key, and inspect and init died on KeyError 'TimeUS'
    with a traceback (exit 1). Such rows cannot be placed in time: inspect, init and replay go on
    without them (exit 0), or say in one line what is missing (exit 2)."""
    from tests.dataflash_writer import write_dataflash
    from tests.test_dataflash import MESSAGES, _flight, _rows

    af, cols = _flight()
    messages = dict(MESSAGES, PARM=("QNf", ["TimeUS", "Name", "Value"]))
    fmt, columns = messages[name]
    messages[name] = (fmt, ["Stamp"] + columns[1:])  # the first column is the time, under another name
    rows = [("PARM", {"TimeUS": 0, "Name": "SIM_WIND_SPD", "Value": 5.0}),
            ("PARM", {"TimeUS": 0, "Name": "SIM_WIND_DIR", "Value": 90.0})] + _rows(af, cols)
    log = write_dataflash(tmp_path / "f.bin", messages, rows)
    for argv in (["inspect", str(log)], ["init", str(log), "--mass", "8", "-o", str(tmp_path / "i.toml")],
                 ["replay", str(M300), str(log), "-o", str(tmp_path / "e.csv")]):
        code = main(argv)
        err = capsys.readouterr().err
        errors = [line for line in err.splitlines() if "warning:" not in line]
        assert code == 0 or (code == 2 and len(errors) == 1 and str(log) in errors[0]), (argv[0], code, err)


@pytest.mark.parametrize("argv", [["inspect", "{log}"], ["replay", str(M300), "{log}", "-o", "{out}"]])
def test_a_gzip_compressed_csv_is_refused_with_the_hint_to_decompress_it(tmp_path, capsys, argv):
    """The tunnel runs come as .csv.gz: read as CSV its first bytes are gzip's magic, and the one line says so
    (before: 'not UTF-8 text', which does not tell a user what to do)."""
    import gzip

    log = tmp_path / "run.csv.gz"
    log.write_bytes(gzip.compress(b"t,vel_n,vel_e,vel_d\n0,1,2,3\n"))
    args = [a.format(log=log, out=tmp_path / "out.csv") for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(log) in err and "gzip-compressed" in err and "gunzip" in err
    assert not (tmp_path / "out.csv").exists()


def test_a_csv_with_quoted_column_names_reads_as_without(tmp_path, capsys):
    """A spreadsheet or pandas export may quote the header ("t","vel_n",...): the names are the same, and so is
    the replay (before: 'column t: missing')."""
    plain = tmp_path / "plain.csv"
    assert main(["simulate", "tunnel", "--hold", "2", "-o", str(plain)]) == 0
    lines = plain.read_text().split("\n")
    k = next(i for i, line in enumerate(lines) if line and not line.startswith("#"))
    lines[k] = ",".join(f'"{name}"' for name in lines[k].split(","))
    quoted = tmp_path / "quoted.csv"
    quoted.write_text("\n".join(lines))
    for log in (plain, quoted):
        assert main(["replay", str(M300), str(log), "-o", str(tmp_path / f"{log.stem}.out.csv")]) == 0
    assert (tmp_path / "plain.out.csv").read_text() == (tmp_path / "quoted.out.csv").read_text()


WILD_US = 1 << 61  # a flipped high bit in a microsecond clock: 2.3e12 s


def _wild_ulog(tmp_path: Path) -> tuple[Path, Path]:
    """A ULog flight, and the same with one vehicle_attitude row's timestamp set to WILD_US."""
    from tests.test_ulog import _flight, _ulog

    _, cols = _flight()
    clean = _ulog(tmp_path / "clean.ulg", cols, landed_until=1.0)
    blob = bytearray(clean.read_bytes())
    at = [o for o, _, kind in _ulog_messages(bytes(blob))
          if kind == "D" and struct.unpack_from("<H", blob, o + 3)[0] == 1][200]  # 1: vehicle_attitude
    struct.pack_into("<Q", blob, at + 5, WILD_US)
    wild = tmp_path / "wild.ulg"
    wild.write_bytes(bytes(blob))
    return clean, wild


def _wild_dataflash(tmp_path: Path) -> tuple[Path, Path]:
    from tests.dataflash_writer import write_dataflash
    from tests.test_dataflash import MESSAGES, _flight, _rows

    af, cols = _flight()
    rows = _rows(af, cols)
    clean = write_dataflash(tmp_path / "clean.bin", MESSAGES, rows)
    k = next(i for i, (name, _) in enumerate(rows) if name == "ATT")
    rows[k] = ("ATT", {**rows[k][1], "TimeUS": WILD_US})
    return clean, write_dataflash(tmp_path / "wild.bin", MESSAGES, rows)


def _wild_csv(tmp_path: Path) -> tuple[Path, Path]:
    from dobwind.io.logs import write_csv
    from dobwind.model.airframe import load_airframe
    from dobwind.simulate.simulate import column_order, simulate

    cols = simulate(load_airframe(M300), "tunnel", seed=2, hold_s=1.0, rate_hz=50.0)
    names = column_order(cols)
    clean = tmp_path / "clean.csv"
    write_csv(clean, names, np.column_stack([cols[n] for n in names]), ["%.17g"] * len(names))
    cols["t"] = cols["t"].copy()
    cols["t"][-1] = WILD_US * 1e-6
    wild = tmp_path / "wild.csv"
    write_csv(wild, names, np.column_stack([cols[n] for n in names]), ["%.17g"] * len(names))
    return clean, wild


@pytest.mark.parametrize("make", [_wild_ulog, _wild_dataflash, _wild_csv])
def test_one_wild_timestamp_does_not_set_the_span(tmp_path, capsys, make):
    """One row stamped 2.3e12 s (a flipped bit; the campaign's DataFlash flips) made inspect report "span
    73 .. 2.3e12 s". The span is now the bulk's, the same as the log without that row's stamp (the CSV's
    bulk ends one row earlier), and the report says one sample lies outside it, where."""
    import json

    clean, wild = make(tmp_path)
    docs = []
    for log in (clean, wild):
        assert main(["inspect", str(log), "--json"]) == 0
        docs.append(json.loads(capsys.readouterr().out))
    want, got = docs
    assert want["outside_span"] == 0 and got["outside_span"] == 1
    assert got["start_s"] == want["start_s"] and got["end_s"] <= want["end_s"] < 1e6
    assert got["outside_span_s"] == [WILD_US * 1e-6, WILD_US * 1e-6]
    assert got["airborne_s"] <= got["duration_s"] < 1e6
    assert any("1 of " in n and "outside the span" in n for n in got["notes"]), got["notes"]
    assert main(["inspect", str(wild)]) == 0
    assert "1 sample outside it" in capsys.readouterr().out


def test_dataflash_ground_events_written_out_of_time_order_read_as_in_order(tmp_path, capsys):
    """replay's DataFlash ground state looked EV events up with searchsorted in file order: a NOT_LANDED
    written after a later LAND_COMPLETE (a buffer flushed late) left the whole flight on the ground (or in
    the air), while inspect sorted them. Both now read the events by time, file order among equal stamps."""
    import json

    from dobwind.io.dataflash import read_dataflash
    from tests.dataflash_writer import write_dataflash
    from tests.test_dataflash import MESSAGES, _flight, _rows

    af, cols = _flight()
    rows = _rows(af, cols, landed_until=1.0)
    rows.append(("EV", {"TimeUS": 1_000_000 + 3_000_000, "Id": 18}))  # LAND_COMPLETE at 3 s: the end of the flight
    rows.sort(key=lambda r: r[1]["TimeUS"])  # stable: the writer's order at equal stamps
    ordered = write_dataflash(tmp_path / "ordered.bin", MESSAGES, rows)
    ev = [r for r in rows if r[0] == "EV"]
    shuffled = write_dataflash(tmp_path / "shuffled.bin", MESSAGES, [r for r in rows if r[0] != "EV"] + ev[::-1])
    want, got = (read_dataflash(str(p), af, rate_hz=50.0) for p in (ordered, shuffled))
    assert 0 < want.landed.mean() < 1  # on the ground before 1 s and after 3 s
    np.testing.assert_array_equal(got.landed, want.landed)
    spans = []
    for log in (ordered, shuffled):
        assert main(["inspect", str(log), "--json"]) == 0
        spans.append(json.loads(capsys.readouterr().out)["airborne_intervals"])
    assert spans[0] == spans[1] == [[2.0, 4.0]]


def _reformatted(blob: bytes, name: str, old: str, new: str) -> bytes:
    """``blob`` with ``old`` replaced by ``new`` in topic ``name``'s format definition ('F' message)."""
    out = bytearray(blob[:16])
    for o, s, kind in _ulog_messages(blob):
        payload = blob[o + 3:o + 3 + s]
        if kind == "F" and payload.split(b":")[0] == name.encode():
            assert old.encode() in payload
            payload = payload.replace(old.encode(), new.encode())
        out += struct.pack("<HB", len(payload), ord(kind)) + payload
    return bytes(out)


@pytest.mark.parametrize("new, why", [
    ("bogus_t[4] q", "type bogus_t is neither a ULog type nor a format"),
    ("float[-1] q", "array size -1"),
    ("float[3] q", "defines 20 bytes a message"),        # a field shortened: the data no longer fits
    ("double[4] q", "defines 40 bytes a message"),       # retyped
    ("vehicle_attitude[4] q", "nests itself"),           # pyulog recursed without end (RecursionError)
])
def test_a_damaged_ulog_format_definition_is_named_as_such_not_missing(tmp_path, capsys, new, why):
    """pyulog drops a topic whose format definition it cannot build or whose messages do not fit it: replay
    said "topic vehicle_attitude (attitude): missing from the log" (the campaign's ulog-fmt-type and
    ulog-fmt-drop mutants), which sends a user to the logger's topic list. It now names the topic and the
    damage, exit 2 in one line; inspect says it in the attitude role."""
    import json

    from tests.test_ulog import _flight, _ulog

    _, cols = _flight()
    clean = _ulog(tmp_path / "clean.ulg", cols, landed_until=1.0)
    log = tmp_path / "damaged.ulg"
    log.write_bytes(_reformatted(clean.read_bytes(), "vehicle_attitude", "float[4] q", new))
    assert main(["replay", str(M300), str(log), "-o", str(tmp_path / "e.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len([e for e in err if "warning:" not in e]) == 1, err
    line = err[-1]
    assert str(log) in line and "topic vehicle_attitude" in line and "damaged" in line and why in line, line
    assert "missing" not in line
    code = main(["inspect", str(log), "--json"])
    done = capsys.readouterr()
    if code == 0:
        doc = json.loads(done.out)
        assert "damaged" in doc["roles"]["attitude"]["note"] and why in doc["roles"]["attitude"]["note"]
        assert any("vehicle_attitude" in n and "damaged" in n for n in doc["notes"])
    else:  # a format nesting itself stops pyulog's whole parse
        assert code == 2 and str(log) in done.err and "vehicle_attitude" in done.err and why in done.err


def test_replay_bounds_true_wind_as_fit_does(tmp_path, capsys):
    """A true-wind cell of 1e308 (finite: the reader took it) overflowed replay's scoring sums: numpy printed
    "RuntimeWarning: overflow encountered in reduce" and the report read "speed error mean inf", exit 0.
    fit refuses true wind beyond +-100 m/s in one line; replay now refuses it with fit's line, no output."""
    from dobwind.io.logs import write_csv
    from dobwind.model.airframe import load_airframe
    from dobwind.simulate.simulate import column_order, simulate

    cols = simulate(load_airframe(M300), "tunnel", seed=2, hold_s=2.0, rate_hz=50.0)
    cols["wind_n"] = cols["wind_n"].copy()
    k = len(cols["t"]) * 3 // 4  # scored: after the warm-up
    cols["wind_n"][k:k + 2] = 1e308
    names = column_order(cols)
    log = tmp_path / "huge.csv"
    write_csv(log, names, np.column_stack([cols[n] for n in names]), ["%.17g"] * len(names))
    lines = {}
    for command, out in (("replay", "e.csv"), ("fit", "f.toml")):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert main([command, str(M300), str(log), "-o", str(tmp_path / out)]) == 2
        assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in caught]
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and str(log) in err[0] and "column wind_n" in err[0], err
        lines[command] = err[0].split(": ", 1)[1]
        assert not (tmp_path / out).exists()
    assert lines["replay"] == lines["fit"]


@pytest.mark.parametrize("rows", [2, None])
@pytest.mark.parametrize("truth", [[], ["--wind", "unknown"]])
def test_every_fit_refusal_on_a_log_names_it(tmp_path, capsys, rows, truth):
    """fit's exit-1 refusals are about the logs ("no airborne row of the logs is accepted and settled",
    "drag family: only 0 usable samples"): on a single log they did not name it (the campaign's csv-1-rows
    and short DataFlash mutants). Every refusal line now names the log."""
    assert main(["simulate", "tunnel", "--hold", "1", "-o", str(tmp_path / "short.csv")]) == 0
    lines = (tmp_path / "short.csv").read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line and not line.startswith("#"))
    log = tmp_path / "log.csv"
    log.write_text("\n".join(lines[:head + 1 + rows] if rows else lines) + "\n")
    capsys.readouterr()
    assert main(["fit", str(M300), str(log), *truth, "-o", str(tmp_path / "f.toml")]) == 1
    errors = [e for e in capsys.readouterr().err.strip().splitlines() if "warning:" not in e]
    assert len(errors) == 1 and str(log) in errors[0], errors
    assert not (tmp_path / "f.toml").exists()


def test_a_refusal_about_many_logs_names_them_shortly():
    from dobwind.cli.fit import naming_logs

    assert naming_logs(["a.csv"], "too short") == "a.csv: too short"
    assert naming_logs(["a.csv", "b.csv"], "too short") == "a.csv, b.csv: too short"
    assert naming_logs([f"{k}.csv" for k in range(5)], "x") == "0.csv, 1.csv and 3 more logs: x"
    assert naming_logs(["a.csv", "b.csv"], "b.csv: no usable sample") == "b.csv: no usable sample"
    assert naming_logs(["a.csv"], "a.csv, row 3: bad") == "a.csv, row 3: bad"
    assert naming_logs(["x/a.csv"], "too short (x/a.csv).") == "too short (x/a.csv)."


def test_a_log_named_only_inside_another_name_is_not_named():
    """'a.csv' inside 'data.csv', 'a.csv.gz' or 'x/a.csv' is another file: the refusal must still name the log."""
    from dobwind.cli.fit import naming_logs

    for message in ("data.csv has no rows", "a.csv.gz is compressed", "x/a.csv: empty", "a.csv-old: empty"):
        assert naming_logs(["a.csv"], message) == f"a.csv: {message}", message


def _swapped_csv(tmp_path: Path, a: str, b: str) -> tuple[Path, int]:
    """A simulated flight CSV whose columns ``a`` and ``b`` trade names (a spreadsheet's column moved), and
    its row count."""
    from dobwind.io.logs import write_csv
    from dobwind.model.airframe import load_airframe
    from dobwind.simulate.simulate import column_order, simulate

    cols = simulate(load_airframe(M300), "tunnel", seed=2, hold_s=2.0, rate_hz=50.0)
    names = column_order(cols)
    data = np.column_stack([cols[n] for n in names])
    i, j = names.index(a), names.index(b)
    names[i], names[j] = names[j], names[i]
    log = tmp_path / f"{a}_{b}.csv"
    write_csv(log, names, data, ["%.17g"] * len(names))
    return log, len(cols["t"])


@pytest.mark.parametrize("a, b, bit", [("q_w", "wind_n", "BAD_QUATERNION"), ("vel_n", "rpm_1", "IMPLAUSIBLE")])
def test_swapped_csv_columns_are_named_as_the_likely_cause(tmp_path, capsys, a, b, bit):
    """q_w holding the wind and wind_n a quaternion component replayed with exit 0, every row rejected, and a
    generic "rows rejected (see the status column ...)". The flight is not refused (a valid log of a bad
    flight may be rejected too), but one stderr line names the reason, its share and the likely cause, and
    the report and --json count the rows per reason."""
    import json

    log, rows = _swapped_csv(tmp_path, a, b)
    assert main(["replay", str(M300), str(log), "-o", str(tmp_path / "e.csv")]) == 0
    done = capsys.readouterr()
    warned = [line for line in done.err.splitlines() if "rejected" in line]
    assert len(warned) == 1, done.err
    assert str(log) in warned[0] and f"rejected as {bit}" in warned[0] and "swapped or mislabelled" in warned[0]
    assert f"{rows} of {rows} rows (100 %)" in warned[0]
    assert f"({bit} {rows}" in done.out
    assert main(["replay", str(M300), str(log), "-o", str(tmp_path / "e.csv"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["rejections"][bit] == rows


def test_a_log_rejected_for_mixed_reasons_keeps_the_general_line():
    from dobwind.replay.rejections import rejection_warning

    assert rejection_warning("f.csv", 100, 10, {"TILT": 10}, 0.05) is None
    mixed = rejection_warning("f.csv", 100, 95, {"TILT": 45, "BAD_THRUST": 50}, 0.05)
    assert mixed is not None and "95 of 100 rows rejected" in mixed and "likely cause" not in mixed
    one = rejection_warning("f.csv", 100, 60, {"BAD_DT": 51, "NONFINITE": 9}, 0.05)
    assert one is not None and "51 of 100 rows (51 %) rejected as BAD_DT" in one and "20 Hz" in one


def _damaged_ulog(tmp_path: Path, how: str) -> tuple[Path, Path]:
    """A ULog flight and a copy damaged mid-file: ``short`` sets a data message's length to 1 (pyulog's parse
    ends there on a struct.error, without a word), ``long`` one's to its size + 7 (pyulog skips it as of no
    size its format defines), ``garbage`` overwrites 4 KiB with 0xff (no message starts there)."""
    from tests.test_ulog import _flight, _ulog

    _, cols = _flight()
    clean = _ulog(tmp_path / "clean.ulg", cols, landed_until=1.0)
    blob = bytearray(clean.read_bytes())
    at, size, _ = [m for m in _ulog_messages(bytes(blob)) if m[2] == "D"][len(blob) // 200]
    if how == "garbage":
        blob[at:at + 4096] = b"\xff" * 4096
    else:
        struct.pack_into("<H", blob, at, 1 if how == "short" else size + 7)
    damaged = tmp_path / f"{how}.ulg"
    damaged.write_bytes(bytes(blob))
    return clean, damaged


@pytest.mark.parametrize("how, said", [("short", "the parse stopped at byte"), ("long", "1 data message(s) of a size"),
                                       ("garbage", "bytes that start no message")])
def test_what_pyulog_drops_without_a_word_is_said(tmp_path, capsys, how, said):
    """The campaign's silent losses: a data message's length set to 1 ended pyulog's parse half-way through
    an octo's log (half its messages and airborne time gone), a length of 65535 or a 4 KiB block of 0xff
    skipped hundreds of messages; inspect and replay said nothing (pyulog only sets its corruption flag).
    inspect now notes it; replay warns on stderr when the parse stopped (the rest is not read), and notes
    skipped messages. The undamaged log says nothing of the kind."""
    import json

    clean, damaged = _damaged_ulog(tmp_path, how)
    notes = {}
    for log in (clean, damaged):
        assert main(["inspect", str(log), "--json"]) == 0
        notes[log] = [n for n in json.loads(capsys.readouterr().out)["notes"] if n.startswith("damaged:")]
    assert notes[clean] == [] and len(notes[damaged]) == 1 and said in notes[damaged][0], notes
    assert main(["replay", str(M300), str(damaged), "-o", str(tmp_path / "e.csv")]) == 0
    done = capsys.readouterr()
    assert said in (done.err if how == "short" else done.out), (done.out, done.err)
    if how == "short":
        assert f"{damaged}: damaged: the parse stopped" in done.err and "s readable)" in done.err


def test_pyulog_takes_data_without_the_trailing_padding_only(tmp_path):
    """ulogformat's rule for the size pyulog takes: the format's without its trailing padding fields, no
    more (a format whose field before the padding was dropped still fitted a size range up to the padded
    size, and a vehicle_attitude pyulog had dropped was called "missing"). Checked on pyulog itself: data
    written with the padding is dropped, and the walk names the topic as damaged."""
    from dobwind.io.ulog import open_ulog
    from dobwind.io.ulogformat import damaged_formats
    from tests.ulog_writer import Topic, write_ulog

    fields = [("uint64_t", "timestamp"), ("float", "x"), ("uint8_t", "reset"), ("uint8_t[3]", "_padding0")]
    rows = [{"timestamp": 1_000_000 + 10_000 * k, "x": float(k)} for k in range(50)]
    padded = write_ulog(tmp_path / "padded.ulg", [Topic("vehicle_attitude", fields, rows)])
    ulog, _ = open_ulog(str(padded))
    assert not [d for d in ulog.data_list if d.name == "vehicle_attitude"]
    why = damaged_formats(str(padded), ["vehicle_attitude"])["vehicle_attitude"]
    assert "defines 13 bytes a message" in why and "50 messages of 16 bytes" in why
    plain = write_ulog(tmp_path / "plain.ulg", [Topic("vehicle_attitude", fields[:3], rows)])
    assert damaged_formats(str(plain), ["vehicle_attitude"]) == {}


def test_a_topic_missing_from_a_damaged_ulog_says_the_file_is_damaged(tmp_path, capsys):
    """A flipped subscription id (the campaign's ulog-a-dup-id, a flip in the definitions) leaves topics out
    of pyulog's parse while it prints one "corrupt" line: replay said only "missing from the log". The line
    now says the file is damaged, with pyulog's words."""
    from tests.test_ulog import _flight, _ulog

    _, cols = _flight()
    blob = bytearray(_ulog(tmp_path / "clean.ulg", cols, landed_until=1.0).read_bytes())
    at = next(o for o, _, kind in _ulog_messages(bytes(blob)) if kind == "A" and blob[o + 6:o + 22] == b"vehicle_attitude")
    struct.pack_into("<H", blob, at + 4, 77)  # its data messages keep id 1: no subscription names them
    log = tmp_path / "damaged.ulg"
    log.write_bytes(bytes(blob))
    assert main(["replay", str(M300), str(log), "-o", str(tmp_path / "e.csv")]) == 2
    err = [e for e in capsys.readouterr().err.strip().splitlines() if "warning:" not in e]
    assert len(err) == 1 and str(log) in err[0] and "topic vehicle_attitude" in err[0], err
    assert "missing from the log; the file is damaged (pyulog: " in err[0] and "no subscription found" in err[0]
