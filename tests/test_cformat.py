"""The compiled row formatter against Python's `%`, byte for byte (harness/cformat.py).

`%` is the independent reference: it is CPython's own correctly rounded conversion, not the code under
test. The values are chosen where a formatter goes wrong: every decade of the double range, the
neighbours of powers of ten and of rounding halves, exact binary ties, signed zeros, NaN, infinities and
subnormals."""
from __future__ import annotations

import io
import shutil

import numpy as np
import pytest

from dobwind.harness.cformat import row_formatter, row_layout
from dobwind.io.logs import CsvWriter

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler")

FLOAT_FORMATS = ["%.6f", "%.6g", "%.7g", "%.9g", "%.0f", "%.3f", "%.1g", "%.9f"]


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("DOBWIND_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def expected_text(data: np.ndarray, formats: list[str]) -> str:
    row = ",".join(formats) + "\n"
    return (row * len(data)) % tuple(data.ravel().tolist())


def assert_same(values: np.ndarray, formats: list[str]) -> None:
    """Every value through every format: each column of the block is the values under one format."""
    data = np.repeat(np.asarray(values, dtype=np.float64)[:, None], len(formats), axis=1)
    got = row_formatter(formats).format(data)
    assert got is not None
    want = expected_text(data, formats)
    if got.decode() != want:
        for g, w, v in zip(got.decode().splitlines(), want.splitlines(), values):
            assert g == w, f"{v!r}: {g} != {w}"
    assert got.decode() == want


def neighbours(x: np.ndarray, ulps: int = 2) -> np.ndarray:
    """x and the doubles up to ``ulps`` steps either side of it."""
    out = [x]
    up, down = x.copy(), x.copy()
    for _ in range(ulps):
        up, down = np.nextafter(up, np.inf), np.nextafter(down, -np.inf)
        out += [up, down]
    return np.concatenate(out)


def test_every_decade_at_random(cache):
    rng = np.random.default_rng(1)
    n = 400_000
    values = rng.uniform(1.0, 10.0, n) * 10.0 ** rng.integers(-320, 308, n) * rng.choice([-1.0, 1.0], n)
    assert_same(values[np.isfinite(values)], FLOAT_FORMATS)


def test_the_magnitudes_a_log_holds(cache):
    rng = np.random.default_rng(2)
    values = np.concatenate([rng.normal(0, 1, 100_000), rng.normal(0, 30, 100_000), rng.uniform(0, 14_400, 100_000),
                             rng.normal(0, 1e-4, 50_000)])
    assert_same(values, FLOAT_FORMATS)
    assert_same(values.astype(np.float32).astype(np.float64), FLOAT_FORMATS)  # replay's single-precision outputs


def test_powers_of_ten_and_their_neighbours(cache):
    powers = np.array([float(f"1e{k}") for k in range(-310, 309)])
    assert_same(neighbours(np.concatenate([powers, -powers]), ulps=3), FLOAT_FORMATS)


def test_near_rounding_halves(cache):
    """Decimals that end in a 5 one digit past each precision (9.999995e-5 for %.6g), their nearest
    doubles and the doubles around them: the cases the fast path hands to snprintf."""
    rng = np.random.default_rng(3)
    texts = []
    for digits in range(1, 11):
        mantissas = rng.integers(10 ** (digits - 1), 10 ** digits, 3000)
        mantissas[:20] = 10 ** digits - 1  # 9.99..95: rounds up into the next decade
        exponents = rng.integers(-30, 30, 3000)
        texts += [f"{m}5e{e}" for m, e in zip(mantissas, exponents)]
    halves = np.array([float(t) for t in texts])
    assert_same(neighbours(np.concatenate([halves, -halves])), FLOAT_FORMATS)


def test_exact_binary_ties_round_half_to_even(cache):
    """odd / 2^(P+1) is a tie for %.Pf; a (P+1)-digit integer ending in 5 is one for %.Pg."""
    odd = np.arange(1, 4001, 2, dtype=np.float64)
    ties = np.concatenate([odd / 2.0 ** p for p in range(1, 12)]
                          + [np.arange(10.0 ** d + 5, 10.0 ** d + 20_000, 10.0) for d in range(1, 11)])
    assert_same(np.concatenate([ties, -ties]), FLOAT_FORMATS)


def test_zeros_infinities_nan_subnormals_and_extremes(cache):
    tiny = np.finfo(np.float64).tiny
    values = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, -np.nan, 5e-324, -5e-324, tiny, -tiny, tiny / 3,
                       np.finfo(np.float64).max, -np.finfo(np.float64).max, 2.0 ** 53, 2.0 ** 53 + 2, 2.0 ** 63,
                       0.5, 1.5, 2.5, 9.5, 0.05, 0.0005, 0.00015, 123456.5, 999999.5, 9999995.0])
    assert_same(values, FLOAT_FORMATS)


def test_integers_truncate_like_python(cache):
    values = np.array([0.0, -0.0, 1.0, -1.0, 2.7, -2.7, 0.5, -0.5, 64.0, 2.0 ** 31, -(2.0 ** 31), 2.0 ** 53,
                       9.1e18, -9.1e18])
    assert_same(values, ["%d"])


def test_what_it_cannot_print_goes_back_to_percent(cache):
    """A %d of NaN or of 1e19 returns None: `%` then prints it or raises Python's own error."""
    formatter = row_formatter(["%d"])
    assert formatter.format(np.array([[np.nan]])) is None
    assert formatter.format(np.array([[1e19]])) is None
    assert formatter.format(np.array([[3]], dtype=np.int64)) is None  # not float: `%` prints integers itself
    with pytest.raises(ValueError):
        CsvWriter(io.StringIO(), ["s"], ["%d"]).write(np.array([[np.nan]]))
    big = io.StringIO()
    CsvWriter(big, ["s"], ["%d"]).write(np.array([[1e19]]))
    assert big.getvalue() == "s\n10000000000000000000\n"


def test_long_fields_go_back_to_percent(cache):
    """%.6f of 1e300 is 308 digits, more than the buffer's room per value: the block falls back whole."""
    data = np.array([[1e300, 1.0]] * 3)
    assert row_formatter(["%.6f", "%.6g"]).format(data) is None
    got = io.StringIO()
    CsvWriter(got, ["a", "b"], ["%.6f", "%.6g"]).write(data)
    assert got.getvalue() == "a,b\n" + expected_text(data, ["%.6f", "%.6g"])


def test_only_the_formats_it_prints_exactly():
    assert row_layout(["%.6f", "%.6g", "%d"]) is not None
    for other in ("%.17g", "%.10f", "%.0g", "%e", "%s", "%6.2f", "%.6g "):
        assert row_layout(["%.6f", other]) is None, other


def test_without_a_compiler_the_writer_uses_percent(cache, monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    assert row_formatter(["%.6g"]) is None
    data = np.array([[1.0 / 3.0, 2.0]])
    got = io.StringIO()
    CsvWriter(got, ["a", "b"], ["%.6g", "%.6f"]).write(data)
    assert got.getvalue() == "a,b\n0.333333,2.000000\n"


def test_the_library_is_cached(cache):
    row_formatter(["%.6g"])
    built = sorted(cache.glob("libformat_rows_*.so"))
    assert len(built) == 1
    stamp = built[0].stat().st_mtime_ns
    row_formatter(["%.3f"])
    assert sorted(cache.glob("libformat_rows_*.so")) == built and built[0].stat().st_mtime_ns == stamp
