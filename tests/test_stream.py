"""Streaming replay: chunked reading, writing, stepping and scoring agree with one pass over the log."""
from __future__ import annotations

import dataclasses
import io
import threading
from pathlib import Path

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.core.errors import InputError
from dobwind.io.logs import CsvWriter, iter_log, read_log, required_columns, write_estimates
from dobwind.model.airframe import load_airframe
from dobwind.model.status import accepted
from dobwind.replay.replay import replay, replay_stream, score
from dobwind.simulate.simulate import write_log

M300 = Path(__file__).resolve().parents[1] / "airframes" / "m300.toml"
# Block sizes (prime numbers of bytes) that cut rows at unrelated places: about 4 and 80 rows.
AWKWARD_BLOCKS = (997, 20011)


@pytest.fixture(scope="module")
def gapped_log(tmp_path_factory) -> str:
    """The tunnel at 50 Hz (eight 8 s segments) with two gaps longer than max_dt cut into it, and comment
    and blank lines inside the data."""
    folder = tmp_path_factory.mktemp("stream")
    whole = folder / "whole.csv"
    write_log(whole, load_airframe(M300), "tunnel", seed=3, hold_s=8.0, rate_hz=50.0)
    lines = whole.read_text().splitlines(keepends=True)
    body_start = next(i for i, line in enumerate(lines) if line.startswith("t,")) + 1
    body = lines[body_start:]
    del body[2000:2040]          # a 0.8 s gap
    del body[1000:1003]          # a short gap
    body.insert(700, "# a comment inside the data\n")
    body.insert(1200, "\n")
    body.insert(1201, "   \n")
    path = folder / "gapped.csv"
    path.write_text("".join(lines[:body_start] + body))
    return str(path)


def _whole_columns(path: str, block_bytes: int) -> dict[str, np.ndarray]:
    chunks = list(iter_log(path, block_bytes=block_bytes))
    assert [c.first_row for c in chunks] == list(np.cumsum([0] + [c.log.rows for c in chunks[:-1]]))
    return {n: np.concatenate([c.log.columns[n] for c in chunks]) for n in chunks[0].log.columns}


def test_chunked_reading_matches_numpy_on_the_clean_rows(gapped_log):
    text = Path(gapped_log).read_text().splitlines()
    header = next(i for i, line in enumerate(text) if line.startswith("t,"))
    rows = [line for line in text[header + 1:] if line.strip() and not line.startswith("#")]
    expected = np.loadtxt(rows, delimiter=",")  # an independent parser on the rows a reader must keep
    for block in AWKWARD_BLOCKS + (1 << 23,):
        got = _whole_columns(gapped_log, block)
        assert np.array_equal(np.column_stack(list(got.values())), expected), block


def test_chunks_carry_true_line_numbers(gapped_log):
    text = Path(gapped_log).read_text().splitlines()
    data_lines = [i + 1 for i, line in enumerate(text)
                  if line.strip() and not line.startswith("#") and not line.startswith("t,")]
    for block in (997, 1 << 23):
        lines = np.concatenate([c.lines for c in iter_log(gapped_log, block_bytes=block)])
        assert lines.tolist() == data_lines


@pytest.mark.parametrize("block", [997, 1 << 23])
def test_bad_cell_after_blank_and_comment_lines_names_its_true_line(tmp_path, block):
    rows = [f"{0.01 * k:.2f},{k}" for k in range(1, 400)]
    rows[300] = "3.01,oops"
    lines = ["# header comment", "t,x"] + rows[:100] + ["", "# inside", "   "] + rows[100:]
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    true_line = lines.index("3.01,oops") + 1
    with pytest.raises(InputError) as err:
        list(iter_log(str(path), block_bytes=block))
    assert str(err.value) == f"{path}: line {true_line}, column x: not a number: 'oops'"


@pytest.mark.parametrize("block", [5, 1 << 23])
def test_time_must_increase_across_chunks_and_short_rows_are_named(tmp_path, block):
    path = tmp_path / "back.csv"
    path.write_text("t,x\n" + "".join(f"{k},{k}\n" for k in range(1, 50)) + "3,1\n")
    with pytest.raises(InputError, match=r"line 51, column t: time must be strictly increasing"):
        list(iter_log(str(path), block_bytes=block))
    path.write_text("t,x\n1,2\n2\n")
    with pytest.raises(InputError, match=r"line 3: has 1 fields, the header has 2"):
        list(iter_log(str(path), block_bytes=block))


@pytest.mark.parametrize("block", [997, 1 << 23])
def test_a_long_row_balanced_by_short_ones_is_named_not_shifted(tmp_path, block):
    """The block's comma total is right (4 extra on line 2, one missing on each of the last 4 lines):
    pandas alone would take the long row's first columns as an index and shift every value."""
    rows = ["1,2,3,4,5,6,7"] + [f"{k},{k},{k}" for k in range(2, 40)] + [f"{k},{k}" for k in range(40, 44)]
    path = tmp_path / "long.csv"
    path.write_text("t,x,y\n" + "\n".join(rows) + "\n")
    with pytest.raises(InputError, match=r"line 2: has 7 fields, the header has 3"):
        list(iter_log(str(path), block_bytes=block))


def test_byte_order_mark_is_not_part_of_the_first_column(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbf# exported\r\nt,x\r\n0.1,1\r\n0.2,nan\r\n0.3,\r\n")
    log = read_log(str(path))
    assert log.time_s.tolist() == [0.1, 0.2, 0.3]
    assert np.isnan(log.columns["x"][1:]).all()


def test_writer_gives_savetxt_text_byte_for_byte():
    rng = np.random.default_rng(5)
    data = rng.normal(size=(9000, 4)) * 10.0 ** rng.integers(-9, 9, size=(9000, 4))
    data[:, 2] = rng.integers(0, 1 << 20, 9000)
    data[7, 1], data[8, 3] = np.nan, -np.inf
    formats = ["%.6f", "%.6g", "%d", "%.7g"]
    expected = io.StringIO()
    np.savetxt(expected, data, fmt=formats, delimiter=",")
    got = io.StringIO()
    CsvWriter(got, ["a", "b", "c", "d"], formats).write(data)
    assert got.getvalue() == "a,b,c,d\n" + expected.getvalue()


@pytest.mark.parametrize("backend,precision", [("python", "double"), ("c", "single"), ("c", "double")])
def test_streamed_replay_is_the_single_pass_bit_for_bit(gapped_log, tmp_path, backend, precision, monkeypatch):
    monkeypatch.setenv("DOBWIND_CACHE", str(tmp_path / "cache"))
    af = load_airframe(M300)
    model, log, traj = replay(af, gapped_log, backend, precision)
    assert (traj.status != 0).any()  # the gaps and warm-up reach the status bits
    expected = tmp_path / "whole.csv"
    write_estimates(expected, log.time_s, traj.outputs, traj.status)
    for block in AWKWARD_BLOCKS[1:] if backend == "python" else AWKWARD_BLOCKS:  # the reference pads every chunk
        out = tmp_path / f"streamed-{block}.csv"
        with open(out, "w") as handle:
            result = replay_stream(af, gapped_log, backend, precision, handle, block_bytes=block)
        assert out.read_bytes() == expected.read_bytes(), block
        whole = score(log, traj, model)
        assert result.metrics["rows"] == whole["rows"] and result.metrics["rejected_rows"] == whole["rejected_rows"]
        _same_table(result.metrics["per_segment"]["table"], whole["per_segment"]["table"])


def _same_table(got: list[dict], expected: list[dict]) -> None:
    assert [(r["segment"], r["samples"]) for r in got] == [(r["segment"], r["samples"]) for r in expected]
    for key in ("true_speed", "est_speed", "vertical_error", "scored_s"):
        assert [r[key] for r in got] == pytest.approx([r[key] for r in expected], rel=1e-12, abs=1e-13)


def test_streamed_score_matches_a_direct_transcription(gapped_log):
    af = load_airframe(M300)
    model, log, traj = replay(af, gapped_log, "python")
    metrics = replay_stream(af, gapped_log, "python", block_bytes=20011).metrics
    wind, truth, t = traj.outputs[:, model.outputs.slice("wind_ned")], log.true_wind, log.time_s
    valid = accepted(traj.status) & (t >= t[0] + 5.0)
    speed = np.abs(np.hypot(*wind[valid, :2].T) - np.hypot(*truth[valid, :2].T))
    assert metrics["per_sample"]["speed_mean"] == pytest.approx(speed.mean(), rel=1e-12)
    assert metrics["per_sample"]["speed_max"] == speed.max()
    seg = log.columns["segment"]
    label = int(seg[len(seg) // 2])
    members = np.flatnonzero(seg == label)
    use = members[valid[members] & (t[members] >= t[members[0]] + 5.0)]
    assert use.size >= 10
    row = next(r for r in metrics["per_segment"]["table"] if r["segment"] == label)
    assert row["samples"] == use.size
    assert row["est_speed"] == pytest.approx(np.hypot(*wind[use, :2].mean(axis=0)), rel=1e-12)
    # The scored span plus one sample period (blocks of 20,011 bytes cut the segment several times).
    assert row["scored_s"] == pytest.approx((t[use[-1]] - t[use[0]]) * use.size / (use.size - 1), rel=1e-12)


def test_library_cache_reuses_one_build_and_survives_concurrent_misses(tmp_path, monkeypatch):
    from dobwind.harness import cstep
    from dobwind.model.exercise import flight_inputs
    from dobwind.model.step import build_step

    monkeypatch.setenv("DOBWIND_CACHE", str(tmp_path / "cache"))
    model = build_step(load_airframe(M300))
    built: list = []
    errors: list = []

    def load() -> None:
        try:
            built.append(cstep.compile_step(model, "double"))
        except Exception as exc:  # noqa: BLE001 (reported below)
            errors.append(exc)

    threads = [threading.Thread(target=load) for _ in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors
    entries = sorted((tmp_path / "cache").iterdir())
    # One library under its two names (the recipe's and the source's), no temporaries.
    assert [p.suffix for p in entries] == [".so", ".so"] and not any(p.name.startswith(".") for p in entries)
    assert entries[0].read_bytes() == entries[1].read_bytes()

    def no_compiler(*args, **kwargs):
        raise AssertionError("a cache hit must not compile, nor generate")

    monkeypatch.setattr(cstep, "build_shared_library", no_compiler)
    from dobwind.codegen import generate  # cstep imports it on a miss only

    monkeypatch.setattr(generate, "generate_code", no_compiler)
    again = cstep.compile_step(model, "double")
    rows = flight_inputs(model, 300, seed=2)
    assert np.array_equal(again.run(rows).outputs, built[0].run(rows).outputs)
    # Another airframe is another recipe: it must generate (and here fails to).
    other = build_step(dataclasses.replace(model.airframe, mass_kg=model.airframe.mass_kg * 1.01))
    with pytest.raises(AssertionError, match="must not compile, nor generate"):
        cstep.compile_step(other, "double")


def test_unusable_cache_folder_only_costs_the_build(tmp_path, monkeypatch):
    from dobwind.harness import cstep
    from dobwind.model.exercise import flight_inputs
    from dobwind.model.step import build_step

    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("DOBWIND_CACHE", str(blocker / "cache"))
    model = build_step(load_airframe(M300))
    rows = flight_inputs(model, 100, seed=1)
    assert np.isfinite(cstep.compile_step(model, "double").run(rows).outputs).all()


def test_replay_json_keeps_stderr_and_stdout_clean(gapped_log, tmp_path, capsys):
    out = tmp_path / "est.csv"
    assert main(["replay", str(M300), gapped_log, "-o", str(out), "--json"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert captured.out.lstrip().startswith("{")
    assert out.read_text().startswith("t,force_n")


def test_failed_streamed_replay_leaves_no_output(tmp_path):
    path = tmp_path / "late.csv"
    af_cols = [c for c, _ in required_columns(load_airframe(M300))] + ["thrust"]
    header = ",".join(dict.fromkeys(af_cols))
    ncol = header.count(",") + 1
    rows = [",".join([f"{0.02 * k:.2f}"] + ["1"] * (ncol - 1)) for k in range(1, 3000)]
    rows[2500] = rows[2500][:-1] + "x"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    out = tmp_path / "est.csv"
    assert main(["replay", str(M300), str(path), "-o", str(out)]) == 2
    assert list(tmp_path.iterdir()) == [path]
