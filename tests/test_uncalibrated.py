"""The UNCALIBRATED quality bit (1 << 10) and the optional `[calibration] status` airframe key (issue #36):
the key round-trips and is validated; a prior airframe's step sets the bit on every accepted sample and
on nothing else, with outputs identical to the calibrated airframe's, in Python and in the generated C;
`fit` writes a calibrated airframe."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from dobwind.calibrate import fitfamily
from dobwind.core.errors import InputError
from dobwind.io.logs import write_csv
from dobwind.model.airframe import CALIBRATED, PRIOR, load_airframe, parse_airframe
from dobwind.model.airframe_toml import dump_airframe, dumps
from dobwind.model.status import NOT_ACCEPTED_MASK, STATUS_BITS, describe
from dobwind.replay.replay import replay
from dobwind.simulate.simulate import simulate
from tests.helpers import M300, airframe_dict

UNCALIBRATED = 1 << 10


def _prior_text() -> str:
    return dumps({**airframe_dict(), "calibration": {"status": PRIOR}})


def test_the_bit_is_a_quality_bit_at_its_allocated_value():
    bit = next(b for b in STATUS_BITS if b.name == "UNCALIBRATED")
    assert bit.value == UNCALIBRATED and not bit.rejects
    assert describe(UNCALIBRATED | 64) == "SETTLING|UNCALIBRATED"
    assert len({b.value for b in STATUS_BITS}) == len(STATUS_BITS)


def test_the_key_defaults_to_calibrated_round_trips_and_is_validated():
    assert parse_airframe(dumps(airframe_dict()), "<t>").calibration == CALIBRATED
    af = parse_airframe(_prior_text(), "<t>")
    assert af.calibration == PRIOR and af.uncalibrated
    assert parse_airframe(dump_airframe(af), "<t>").calibration == PRIOR
    # A calibrated airframe's file does not carry the table (files written before it existed read back).
    assert "[calibration]" not in dump_airframe(dataclasses.replace(af, calibration=CALIBRATED))
    for bad, where in (('status = "maybe"', "calibration.status"), ("status = 1", "calibration.status"),
                       ('state = "prior"', "calibration.state")):
        with pytest.raises(InputError) as err:
            parse_airframe(_prior_text().replace('status = "prior"', bad), "x.toml")
        assert err.value.where == where and str(err.value).startswith("x.toml: ")


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    af = load_airframe(M300)
    cols = simulate(af, "tunnel", seed=2, hold_s=1.0, rate_hz=50.0)
    cols["vel_n"][100:110] = np.nan  # rejected rows: they must not carry the quality bit
    path = tmp_path_factory.mktemp("uncal") / "f.csv"
    names = [n for n in cols if n != "segment"]
    write_csv(path, names, np.column_stack([cols[n] for n in names]), ["%.9g"] * len(names))
    prior = parse_airframe(M300.read_text() + '\n[calibration]\nstatus = "prior"\n', "prior.toml")
    return af, prior, str(path)


def test_the_step_sets_it_on_every_accepted_sample_and_changes_nothing_else(flight):
    af, prior, path = flight
    _, _, cal = replay(af, path)
    _, _, pri = replay(prior, path)
    accepted = (cal.status.astype(np.int64) & NOT_ACCEPTED_MASK) == 0
    assert accepted.sum() > 100 and (~accepted).sum() >= 10
    np.testing.assert_array_equal(pri.outputs, cal.outputs)
    np.testing.assert_array_equal(pri.status[accepted], cal.status[accepted] | UNCALIBRATED)
    np.testing.assert_array_equal(pri.status[~accepted], cal.status[~accepted])
    assert not np.any(cal.status.astype(np.int64) & UNCALIBRATED)


def test_the_generated_c_sets_it_like_the_reference(flight):
    _, prior, path = flight
    _, _, ref = replay(prior, path)
    _, _, c = replay(prior, path, backend="c", precision="double")
    np.testing.assert_array_equal(c.status, ref.status)
    assert np.all(c.status[(ref.status.astype(np.int64) & NOT_ACCEPTED_MASK) == 0] & UNCALIBRATED)


def test_the_c_header_and_check_name_it(tmp_path, capsys):
    from dobwind.cli.app import main

    (tmp_path / "p.toml").write_text(_prior_text())
    assert main(["generate", str(tmp_path / "p.toml"), "-o", str(tmp_path / "c")]) == 0
    capsys.readouterr()
    header = next((tmp_path / "c").glob("*.h")).read_text()
    assert "STATUS_UNCALIBRATED 0x400u" in header and "calibration     prior" in header
    assert main(["check", str(tmp_path / "p.toml"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["calibration"] == PRIOR


def test_fit_starts_from_the_calibrated_state(monkeypatch):
    seen = []

    class Stop(Exception):
        pass

    def capture(af, paths, options):
        seen.append(af.calibration)
        raise Stop

    monkeypatch.setattr(fitfamily, "_fit_once", capture)
    with pytest.raises(Stop):
        fitfamily.fit_airframe(parse_airframe(_prior_text(), "<t>"), ["unused.csv"])
    assert seen == [CALIBRATED]


def test_replay_warns_once(flight, tmp_path, capsys):
    from dobwind.cli.app import main

    _, prior, path = flight
    (tmp_path / "p.toml").write_text(M300.read_text() + '\n[calibration]\nstatus = "prior"\n')
    assert main(["replay", str(tmp_path / "p.toml"), path, "--json"]) == 0
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and "uncalibrated prior" in err and "UNCALIBRATED" in err and "p.toml" in err
    assert json.loads(out)["trusted_share"] == 0.0  # status 0 is never reached
    assert main(["replay", str(M300), path]) == 0
    assert capsys.readouterr().err == ""
