"""The compiled CSV block parser (harness/cparse.py) against Python's float(), bit for bit.

float() is the independent reference (CPython's correctly rounded conversion, the careful pass's own);
the cells are written the ways logs write numbers, and the ways that are hard to round: 17 to 25
significant digits, exponents beyond 10^22, halfway decimals, subnormals, leading zeros."""
from __future__ import annotations

import io
import shutil
from decimal import Decimal, getcontext

import numpy as np
import pytest

from dobwind.io.csvchunks import Header, read_blocks
from dobwind.harness.cparse import block_parser

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler")


@pytest.fixture()
def parser(tmp_path, monkeypatch):
    monkeypatch.setenv("DOBWIND_CACHE", str(tmp_path / "cache"))
    return block_parser()


def assert_parses_like_float(parser, cells: list[str], ncols: int = 4) -> None:
    cells = cells + [""] * (-len(cells) % ncols)
    rows = [",".join(cells[i:i + ncols]) for i in range(0, len(cells), ncols)]
    got = parser.parse(("\n".join(rows) + "\n").encode(), ncols, len(rows))
    assert got is not None
    want = np.array([float(c) if c else np.nan for c in cells]).reshape(len(rows), ncols)
    bad = got.view(np.int64) != want.view(np.int64)
    assert not bad.any(), [(cells[i], got.ravel()[i], want.ravel()[i]) for i in np.flatnonzero(bad.ravel())[:5]]


def random_doubles(rng, n: int) -> np.ndarray:
    bits = rng.integers(0, 2 ** 63 - 1, n, dtype=np.int64) | (rng.integers(0, 2, n, dtype=np.int64) << 63)
    values = bits.view(np.float64)
    return values[np.isfinite(values)]


def test_numbers_as_logs_write_them(parser):
    rng = np.random.default_rng(4)
    values = np.concatenate([rng.normal(0, 1, 50_000), rng.normal(0, 30, 50_000), rng.uniform(0, 14_400, 50_000),
                             rng.normal(0, 1e-4, 20_000) * 10.0 ** rng.integers(-30, 30, 20_000)])
    for fmt in ("%.6f", "%.7g", "%.9g", "%.17g", "%r", "%.3e", "%.12E", "%.0f", "%.20f"):
        cells = [fmt % v if fmt != "%r" else repr(float(v)) for v in values[:30_000]]
        assert_parses_like_float(parser, cells)


def test_every_double_written_shortest_and_long(parser):
    rng = np.random.default_rng(5)
    values = random_doubles(rng, 100_000)  # every exponent, subnormals included
    assert_parses_like_float(parser, [repr(float(v)) for v in values])
    assert_parses_like_float(parser, ["%.25e" % v for v in values[:30_000]])


def test_halfway_decimals(parser):
    """Decimals exactly halfway between two doubles, and the decimals next to them at 30 digits: the
    hardest to round (the exact midpoint comes from Decimal, not from the code under test)."""
    getcontext().prec = 800
    rng = np.random.default_rng(6)
    cells = []
    for v in np.abs(random_doubles(rng, 10_000)):
        up = float(np.nextafter(v, np.inf))
        if np.isfinite(up):
            mid = (Decimal(float(v)) + Decimal(up)) / 2
            exact = f"{mid:e}"
            cells += ([exact] if len(exact) <= 400 else []) + [f"{mid:.30e}", f"{mid.next_plus():.30e}",
                                                              f"{mid.next_minus():.30e}"]
    assert_parses_like_float(parser, cells)
    assert parser.parse(b"1." + b"0" * 400 + b"1\n", 1, 1) is None  # longer cells: the careful pass


def test_spellings_float_reads(parser):
    cells = ["0", "-0", "+0", "-0.0", "000123.500", ".5", "5.", "-.5", "+5.", "1E5", "1e+05", "1e-05", "-1.5E-3",
             "1e400", "-1e400", "1e-400", "4.9e-324", "2.4e-324", "2.5e-324", "1e00000000000000000000005",
             "123456789012345678901234567890", "0.000000000000000000000000000001234", "9007199254740993",
             "9007199254740992", "18446744073709551615", "18446744073709551616", "99999999999999999999e-5",
             "nan", "NaN", "-nan", "inf", "-inf", "+inf", "Inf", "INFINITY", "-Infinity", "1.7976931348623157e308",
             "1.7976931348623158e308", "2.2250738585072011e-308", "2.2250738585072014e-308"]
    assert_parses_like_float(parser, cells, ncols=1)
    got = parser.parse(b"-nan,nan\n", 2, 1)
    assert np.signbit(got[0, 0]) and not np.signbit(got[0, 1])  # float("-nan") keeps its sign


@pytest.mark.parametrize("text", ["1,2\n\n3,4\n", "1,2\n# note\n3,4\n", "1,2\n3\n", "1,2\n3,4,5\n", "1, 2\n",
                                  "1_0,2\n", "0x10,2\n", "1e,2\n", ".,2\n", "-,2\n", "e5,2\n", "1.2.3,2\n",
                                  "nan1,2\n", "infinit,2\n", "1,2\r\n\r\n3,4\r\n", "1,2 \n", "1\r,2\n", "1,,2\n"])
def test_anything_else_is_left_to_the_careful_pass(parser, text):
    lines = text.count("\n") + (0 if text.endswith("\n") else 1)
    assert parser.parse(text.encode(), 2, lines) is None


@pytest.mark.parametrize("text", ["", "\n", "a", "a\n", "a\nb", "a\nb\n", "\n\n\n", "a\r\nb\r\n", "x" * 5000 + "\n" * 3])
def test_line_count_is_the_readers(parser, text):
    from dobwind.io.csvchunks import _line_count

    data = text.encode() + b"tail after the end"
    assert parser.count_lines(data, len(text)) == (_line_count(data, len(text)) if text else 0)
    assert parser.count_lines(data, len(text)) == len(text.splitlines())


def test_more_lines_than_counted_are_refused(parser):
    assert parser.parse(b"1,2\n3,4\n", 2, 1) is None
    assert parser.parse(b"1,2\n3,4\n", 2, 3) is None  # fewer: the caller's count was wrong, not the block


def test_line_ends(parser):
    assert parser.parse(b"1,2\r\n3,4\r\n", 2, 2).tolist() == [[1.0, 2.0], [3.0, 4.0]]
    assert parser.parse(b"1,2\n3,4", 2, 2).tolist() == [[1.0, 2.0], [3.0, 4.0]]
    assert np.isnan(parser.parse(b",\n", 2, 1)).all()
    assert parser.parse(b"\n", 1, 1) is None  # a blank line of a one-column log is skipped, not a NaN


def test_blocks_match_pandas_where_both_read_them(parser, tmp_path):
    """The compiled reader and pandas (compiled=False) give the same doubles for the ways logs are
    written (simulate's %.6f and %.7g, %.9g, shortest round-trip digits)."""
    rng = np.random.default_rng(7)
    data = np.column_stack([np.arange(3000) * 0.01, rng.normal(0, 1, (3000, 4)) * [1, 30, 1e-4, 1e-12]])
    text = "t,a,b,c,d\n" + "".join("%.6f,%.7g,%.7g,%.9g,%r\n" % (*row[:4], float(row[4])) for row in data)
    header = Header(["t", "a", "b", "c", "d"], 1)
    blocks = [list(read_blocks(_body(text), header, "x.csv", 4096, compiled=c)) for c in (True, False)]
    assert len(blocks[0]) == len(blocks[1]) > 1
    for ours, theirs in zip(*blocks):
        assert ours.data.view(np.int64).tolist() == theirs.data.view(np.int64).tolist()
        assert ours.lines.tolist() == theirs.lines.tolist()


def _body(text: str) -> io.BytesIO:
    handle = io.BytesIO(text.encode())
    handle.readline()
    return handle


def test_without_a_compiler_the_reader_uses_pandas(tmp_path, monkeypatch):
    from dobwind.io.logs import read_log

    monkeypatch.setenv("DOBWIND_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("CC", "/nonexistent/cc")
    assert block_parser() is None
    path = tmp_path / "log.csv"
    path.write_text("t,x\n0.1,1.5\n0.2,\n0.3,-2e-3\n")
    log = read_log(str(path))
    assert log.time_s.tolist() == [0.1, 0.2, 0.3] and log.columns["x"][2] == -2e-3 and np.isnan(log.columns["x"][1])


def test_an_unusable_cache_folder_still_gives_a_parser(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("DOBWIND_CACHE", str(blocker / "cache"))
    assert block_parser().parse(b"1,2\n", 2, 1).tolist() == [[1.0, 2.0]]
