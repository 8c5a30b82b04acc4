"""`fit` on absurd calibration logs (issue #16): one stderr line and exit 2 for a true wind no vehicle
flies in, a handled result (never a traceback, never an infinite coefficient) for missing truth and
for a log too short to hold a calibration point beside a good one."""
from __future__ import annotations

import math
import traceback
from pathlib import Path

import pytest

from dobwind.cli.app import main
from dobwind.io.logs import TRUE_WIND_MAX_MPS
from dobwind.model.airframe import load_airframe
from tests.helpers import M300


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> list[str]:
    path = tmp_path_factory.mktemp("fit") / "good.csv"
    assert main(["simulate", "tunnel", "--hold", "6", "--rate", "50", "--seed", "3", "-o", str(path)]) == 0
    return path.read_text().splitlines()


def _header(lines: list[str]) -> int:
    return next(i for i, line in enumerate(lines) if not line.startswith("#"))


def _with_cell(lines: list[str], column: str, rows: range, value: str) -> list[str]:
    h = _header(lines)
    c = lines[h].split(",").index(column)
    out = list(lines)
    for r in rows:
        cells = out[h + 1 + r].split(",")
        cells[c] = value
        out[h + 1 + r] = ",".join(cells)
    return out


def _fit(tmp_path: Path, logs: dict[str, list[str]], capsys) -> tuple[int, str, Path]:
    paths = []
    for name, lines in logs.items():
        paths.append(tmp_path / name)
        paths[-1].write_text("\n".join(lines) + "\n")
    out = tmp_path / "new.toml"
    try:
        code = main(["fit", str(M300), *map(str, paths), "-o", str(out)])
    except Exception:  # noqa: BLE001 - the finding this test exists for
        pytest.fail(traceback.format_exc())
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err, out


@pytest.mark.parametrize("value", ["1e300", "-1e300", "inf", "-inf", "1e6", f"{TRUE_WIND_MAX_MPS * 1.01:g}"])
@pytest.mark.parametrize("column", ["wind_n", "wind_d"])
def test_a_true_wind_no_vehicle_flies_in_is_refused_with_its_line(value, column, good, tmp_path, capsys):
    bad = _with_cell(good, column, range(40, len(good) - _header(good) - 1), value)
    code, err, out = _fit(tmp_path, {"good.csv": good, "bad.csv": bad}, capsys)
    line = _header(good) + 1 + 40 + 1  # file lines count from 1
    assert code == 2
    assert err.splitlines() == [err.strip()] and f"bad.csv: line {line}, column {column}:" in err
    assert not out.exists()


def _finite_coefficients(path: Path) -> bool:
    af = load_airframe(path)
    values = [*af.horizontal.coefficients, *af.vertical.coefficients, af.thrust.scale, *af.observer.force_offset_n]
    if af.drag is not None:
        values += [getattr(af.drag, k) for k in af.drag.keys()]
    return all(math.isfinite(v) for v in values)


def test_nan_in_the_true_wind_is_a_missing_value(good, tmp_path, capsys):
    holed = _with_cell(good, "wind_e", range(100, 160), "nan")
    holed = _with_cell(holed, "wind_n", range(500, 510), "")
    code, err, out = _fit(tmp_path, {"holed.csv": holed}, capsys)
    assert code in (0, 1), err
    if code == 0:
        assert _finite_coefficients(out)
    else:
        assert not out.exists() and "nothing written" in err


@pytest.mark.parametrize("rows", [1, 3, 50, 140])
def test_a_log_too_short_to_calibrate_beside_a_good_one_is_handled(rows, good, tmp_path, capsys):
    short = good[:_header(good) + 1 + rows]  # 50 Hz: 0.02 to 2.8 s, shorter than the smoothing window
    code, err, out = _fit(tmp_path, {"good.csv": good, "short.csv": short}, capsys)
    assert code in (0, 1), err
    assert "short.csv" in err  # named: it contributed nothing, or failed the self-check
    if code == 0:
        assert _finite_coefficients(out)
    else:
        assert not out.exists()


def test_a_fitted_airframe_the_loader_would_refuse_is_not_written():
    # fit's output goes through the loader first (a thrust scale of 20 from logs in the wrong unit).
    from dobwind.cli.fit import refuse_out_of_range
    from dobwind.core.errors import InputError
    from dobwind.model.airframe_toml import dumps
    from tests.helpers import airframe_dict

    refuse_out_of_range(dumps(airframe_dict()), "new.toml")  # a good one passes
    with pytest.raises(InputError, match=r"new.toml: thrust.scale: the fitted airframe would be refused"):
        refuse_out_of_range(dumps(airframe_dict(**{"thrust.scale": 20.0})), "new.toml")
