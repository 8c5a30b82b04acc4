"""`fit --json` against its declared schema (docs/schemas/fit-report.schema.json, issue #34): real fit
reports validate (both families, tunnel runs with an outlier, --wind unknown), so does a report with every
nested part filled; the schema names every FitReport field and every part's keys in their printed order;
a renamed, retyped, extra or missing key fails, at the top and in each nested part. The validator below
covers the subset of JSON Schema the file uses (type, enum, properties, required, dependentRequired,
additionalProperties, items, minItems/maxItems, anyOf, $ref to $defs): jsonschema is not a dependency of
the project."""
from __future__ import annotations

import contextlib
import copy
import dataclasses
import io
import json
from typing import Any

import pytest

from dobwind.calibrate.accelroute import blend_record
from dobwind.calibrate.fit import FitReport
from dobwind.calibrate.holdcv import HoldCV
from dobwind.calibrate.reportparts import FamilyScores, HoldScores, LogCheck, LowPassChange, Segment, SelfCheck
from dobwind.calibrate.runmeans import RunVerdict
from dobwind.calibrate.selfcheck import Thresholds, verdict
from dobwind.cli.app import main
from dobwind.io.jsonout import dumps
from dobwind.model.airframe import load_airframe
from tests.helpers import ROOT

SCHEMA = json.loads((ROOT / "docs" / "schemas" / "fit-report.schema.json").read_text(encoding="utf-8"))
ADDED_BY_THE_COMMAND = ["written", "airframe", "plot"]  # dobwind/cli/fit.py, after the report's fields
AIRFRAME = ROOT / "benchmarks" / "vehicles" / "px4quad.airframe.toml"
VEHICLE = ROOT / "benchmarks" / "vehicles" / "px4quad.vehicle.toml"
TYPES = {"object": dict, "array": list, "string": str, "boolean": bool, "null": type(None)}


def _is(value: Any, name: str) -> bool:
    if name in ("number", "integer"):  # bool is an int in Python, never a number in JSON
        wanted = int if name == "integer" else (int, float)
        return isinstance(value, wanted) and not isinstance(value, bool)
    return isinstance(value, TYPES[name])


def errors(value: Any, schema: dict, where: str = "$", root: dict = SCHEMA) -> list[str]:
    """Every way ``value`` breaks ``schema``, each with its JSON path."""
    if "$ref" in schema:
        return errors(value, root["$defs"][schema["$ref"].removeprefix("#/$defs/")], where, root)
    if "anyOf" in schema:
        found = [errors(value, option, where, root) for option in schema["anyOf"]]
        return [] if any(not f for f in found) else [f"{where}: matches no anyOf option ({found[0][0]})"]
    names = schema.get("type", [])
    names = [names] if isinstance(names, str) else names
    if names and not any(_is(value, n) for n in names):
        return [f"{where}: {type(value).__name__} is not {'/'.join(names)}"]
    if "enum" in schema and value not in schema["enum"]:
        return [f"{where}: {value!r} not in {schema['enum']}"]
    if isinstance(value, dict):
        return _object_errors(value, schema, where, root)
    if isinstance(value, list):
        out = [f"{where}: {len(value)} items, {bound} {schema[key]}" for key, bound, bad in
               (("minItems", "at least", len(value) < schema.get("minItems", 0)),
                ("maxItems", "at most", len(value) > schema.get("maxItems", len(value)))) if bad]
        return out + [e for i, item in enumerate(value) for e in errors(item, schema.get("items", {}), f"{where}[{i}]", root)]
    return []


def _object_errors(value: dict, schema: dict, where: str, root: dict) -> list[str]:
    out = [f"{where}: missing {key!r}" for key in schema.get("required", []) if key not in value]
    out += [f"{where}: {key!r} without {other!r}" for key, others in schema.get("dependentRequired", {}).items()
            if key in value for other in others if other not in value]
    properties, extra = schema.get("properties", {}), schema.get("additionalProperties", True)
    for key, item in value.items():
        if key in properties:
            out += errors(item, properties[key], f"{where}.{key}", root)
        elif extra is False:
            out.append(f"{where}: unexpected {key!r}")
        elif isinstance(extra, dict):
            out += errors(item, extra, f"{where}.{key}", root)
    return out


def _run(argv: list[str]) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = main(argv)
    return code, out.getvalue()


@pytest.fixture(scope="module")
def reports(tmp_path_factory) -> dict[str, dict]:
    """Real `fit --json` reports on a small simulated quadcopter (12.5 Hz, 10 s holds): the family
    chosen among all, and the polynomial family alone."""
    folder = tmp_path_factory.mktemp("fitschema")
    logs = []
    for scenario, seed in (("sweep", 5), ("vertical", 6)):
        logs.append(str(folder / f"{scenario}.csv"))
        assert _run(["simulate", scenario, "--airframe", str(AIRFRAME), "--vehicle", str(VEHICLE), "--rate", "12.5",
                     "--hold", "10", "--seed", str(seed), "-o", logs[-1]])[0] == 0
    found = {}
    for model in ("auto", "polynomial"):
        code, text = _run(["fit", str(AIRFRAME), *logs, "--model", model, "--force", "--json",
                           "-o", str(folder / f"{model}.toml")])
        assert code == 0, text
        found[model] = json.loads(text)
    return found


@pytest.fixture(scope="module")
def field_reports(tmp_path_factory) -> dict[str, dict]:
    """Real reports of the other shapes: four tunnel-style runs, one of them flown by a vehicle with
    another thrust scale and drag (per-log runs, an anchored law, an outlier), and --wind unknown on a box
    flight (the command's wind_truth)."""
    folder = tmp_path_factory.mktemp("fitschema_field")
    odd = folder / "odd.vehicle.toml"
    odd.write_text(VEHICLE.read_text().replace("scale = 1.05", "scale = 1.25").replace("quadratic = 0.035", "quadratic = 0.07"))
    tunnels = []
    # 8 s holds, not the tunnel's 20: the fit takes a quarter of the time and still anchors the law and
    # flags the odd vehicle's run alone (the three others are not outliers)
    for seed, vehicle in ((1, VEHICLE), (2, VEHICLE), (3, VEHICLE), (4, odd)):
        tunnels.append(str(folder / f"tunnel{seed}.csv"))
        assert _run(["simulate", "tunnel", "--airframe", str(AIRFRAME), "--vehicle", str(vehicle), "--rate", "12.5",
                     "--hold", "8", "--seed", str(seed), "-o", tunnels[-1]])[0] == 0
    box = str(folder / "box.csv")  # 4 s holds: the wind is still identified, the solve takes half the time
    assert _run(["simulate", "box", "--airframe", str(AIRFRAME), "--vehicle", str(VEHICLE), "--hold", "4",
                 "--seed", "5", "-o", box])[0] == 0
    found = {}
    for name, argv in (("tunnel", tunnels), ("wind unknown", [box, "--wind", "unknown", "--model", "drag-heading"])):
        code, text = _run(["fit", str(AIRFRAME), *argv, "--force", "--json", "-o", str(folder / "fit.toml")])
        assert code == 0, text
        found[name] = json.loads(text)
    return found


def test_tunnel_runs_and_wind_unknown_reports_match_the_schema(field_reports):
    tunnel, unknown = field_reports["tunnel"], field_reports["wind unknown"]
    assert errors(tunnel, SCHEMA) == [] and errors(unknown, SCHEMA) == []
    assert tunnel["anchored"] and any(run["outlier"] for run in tunnel["runs"]) and "wind_truth" in unknown


@pytest.mark.parametrize("model", ["auto", "polynomial"])
def test_real_fit_reports_match_the_schema(reports, model):
    report = reports[model]
    assert errors(report, SCHEMA) == []
    assert (model == "auto" or report["model"] == "polynomial") and report["self_check"]["logs"]


def test_a_fit_with_climbs_reports_a_zero_score_its_vertical_cv_beats(reports):
    """The simulated vehicle climbs and descends: the truth has vertical airflow (zero's score is not
    zero) and the fitted vertical law predicts it better than zero does."""
    report = reports["auto"]
    assert report["vertical_zero_rmse_mps"] > 0.1
    assert report["vertical_cv_rmse_mps"] < report["vertical_zero_rmse_mps"]
    # ... by more than the blocks' scatter: the share (the square of their ratio) plus two standard errors
    share, se = report["vertical_unexplained_share"], report["vertical_unexplained_share_se"]
    assert share == pytest.approx((report["vertical_cv_rmse_mps"] / report["vertical_zero_rmse_mps"]) ** 2, rel=1e-6)
    assert 0 < se and share + 2 * se < 1


def test_the_schema_names_every_field_of_the_report_in_its_order():
    fields = [f.name for f in dataclasses.fields(FitReport)]
    declared = list(SCHEMA["properties"])
    assert declared[:len(fields)] == fields and SCHEMA["required"] == fields + ADDED_BY_THE_COMMAND
    assert list(FitReport().as_dict()) == fields


def test_a_renamed_or_retyped_field_fails(reports):
    report = reports["auto"]
    renamed = {("thrust_factor" if k == "thrust_scale" else k): v for k, v in report.items()}
    assert errors(renamed, SCHEMA) == ["$: missing 'thrust_scale'", "$: unexpected 'thrust_factor'"]
    nested = copy.deepcopy(report)
    nested["self_check"]["ok"] = nested["self_check"].pop("passed")
    assert errors(nested, SCHEMA) == ["$.self_check: missing 'passed'", "$.self_check: unexpected 'ok'"]
    retyped = {**report, "points": str(report["points"]), "runs": [{**r, "outlier": 1} for r in report["runs"]][:1]}
    assert errors(retyped, SCHEMA)[0] == "$.points: str is not integer"
    assert (errors(retyped, SCHEMA)[1:] == ["$.runs[0].outlier: int is not boolean"]) == bool(report["runs"])


def test_the_validator_on_known_cases():
    schema = {"type": "object", "required": ["a"], "additionalProperties": {"type": "number"},
              "properties": {"a": {"anyOf": [{"$ref": "#/$defs/pair"}, {"type": "null"}]}},
              "$defs": {"pair": {"type": "array", "items": {"type": "integer"}, "minItems": 2, "maxItems": 2}}}
    assert errors({"a": [1, 2], "b": 0.5}, schema, root=schema) == []
    assert errors({"a": None}, schema, root=schema) == []
    assert errors({"a": [1, True]}, schema, root=schema)[0].startswith("$.a: matches no anyOf option")
    assert errors({"b": "x"}, schema, root=schema) == ["$: missing 'a'", "$.b: str is not number"]
    assert errors([1], {"type": "array", "minItems": 2}) == ["$: 1 items, at least 2"]
    together = {"type": "object", "dependentRequired": {"a": ["b"]}}
    assert errors({"a": 1, "b": 2}, together) == [] and errors({"b": 2}, together) == []
    assert errors({"a": 1}, together) == ["$: 'a' without 'b'"]
    assert errors("drag-heading", {"type": "string", "enum": ["drag"]}) == ["$: 'drag-heading' not in ['drag']"]


def test_the_report_is_frozen_and_its_dict_a_copy():
    report = every_part()
    with pytest.raises(dataclasses.FrozenInstanceError):
        report.points = 3  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        report.self_check.logs[0].segments[0].points = 3  # type: ignore[misc, union-attr]
    document = report.as_dict()
    document["warnings"].append("b")
    document["runs"][0]["log"] = "y.csv"
    document["self_check"]["logs"][0]["segments"][0]["points"] = -1
    document["families"]["drag"]["hold_cv_by_speed"]["speeds_mps"].append(9.0)
    assert report.warnings == ["a warning"] and report.runs[0].log == "a.csv"
    assert report.self_check.logs[0].segments[0].points == 40  # type: ignore[union-attr]
    assert report.families["drag"].hold.by_speed.speeds_mps == (1.0, 5.0)  # type: ignore[union-attr]


# A report with every nested part filled, through the builders where they are public (the self-check's
# verdict, the blend's record, the hold-level CV's bands), so what they print is what is validated.
def _self_check() -> SelfCheck:
    segments = [Segment(0, 0.4, 0.05, None, -0.01, 40), Segment(1, 6.0, -0.1, 2.5, 0.02, 60)]
    log = LogCheck("a.csv", 500, 200, 100, segments, 0.08, 0.1, 2.5, 2.5, 0.05, 0.04, 98, 0.03, 38)
    return verdict(load_airframe(AIRFRAME), [log], 0.07, 6.0, Thresholds(outlier_logs=("b.csv",)))


def every_part() -> FitReport:
    hold = HoldCV(0.07, (1.0, 5.0), (0.08, 0.06), 0.1, (0.05, 0.04), (0.06, 0.05), 3.0)
    held = HoldScores(hold.rms_mps, hold.band_table(), hold.extrapolation_mps)
    drag = FamilyScores(0.2, 0.1, 0.25, 0.22, held, run_loss=0.4, exponent=1.8)
    check = _self_check()
    blended = dataclasses.replace(check, still_noise_mps=0.02)
    route = blend_record(load_airframe(AIRFRAME), check, blended, True, ratio=0.5)
    return FitReport(points=100, model="drag", drag={"l0": 0.1, "q0": 0.03, "kappa": 0.01, "exponent": 1.8},
                     families={"drag": drag, "polynomial": None}, samples=100, hold_cv_speed_mps=held.cv_speed_mps,
                     hold_cv_by_speed=held.by_speed, hold_extrapolation_speed_mps=held.extrapolation_speed_mps,
                     self_check=check, low_pass=LowPassChange((0.2, 0.1), (0.05, 0.03), 0.04), acceleration_route=route,
                     exponent_scores={"1.8": 0.07, "2": 0.08}, anchored=True,
                     runs=[RunVerdict("a.csv", 4.0, 0.1, 1.0, False), RunVerdict("b.csv", 6.0, 1.2, 0.0, True)],
                     warnings=["a warning"])


def _printed(report: FitReport) -> dict[str, Any]:
    """The report as `fit --json` prints it (tuples as lists, non-finite numbers as null)."""
    return json.loads(dumps({**report.as_dict(), "written": True, "airframe": "new.toml", "plot": "new_fit.png"}))


def test_a_report_with_every_part_matches_the_schema():
    report = _printed(every_part())
    assert errors(report, SCHEMA) == []
    # every part is there, filled: what the cases below break is really printed
    assert report["families"]["polynomial"] == {} and report["self_check"]["logs"][0]["segments"]
    assert all(report[k] for k in ("low_pass", "acceleration_route", "runs", "hold_cv_by_speed"))


def test_parts_the_fit_did_not_make_print_as_empty_objects():
    report = _printed(FitReport(families={"polynomial": None}))
    assert [report[k] for k in ("low_pass", "acceleration_route", "self_check")] == [{}, {}, {}]
    assert report["families"] == {"polynomial": {}} and report["hold_cv_by_speed"] is None
    assert errors(report["low_pass"], SCHEMA["properties"]["low_pass"]) == []
    assert errors(report["families"], SCHEMA["properties"]["families"]) == []


# Each nested part, the schema's name for it, and where the full report prints one.
PARTS = [("selfCheck", "self_check"), ("logCheck", "self_check.logs.0"), ("segment", "self_check.logs.0.segments.0"),
         ("holdCvBySpeed", "hold_cv_by_speed"), ("familyScores", "families.drag"), ("lowPass", "low_pass"),
         ("accelerationRoute", "acceleration_route"), ("run", "runs.0")]


def _at(document: Any, path: str) -> Any:
    for key in path.split("."):
        document = document[int(key)] if isinstance(document, list) else document[key]
    return document


@pytest.mark.parametrize("name,path", PARTS)
def test_each_part_prints_the_keys_its_schema_declares_in_order(name, path):
    declared = SCHEMA["$defs"][name]
    printed = _at(_printed(every_part()), path)
    assert list(printed) == list(declared["properties"]) and declared["additionalProperties"] is False
    # a part that always prints every key requires every key (FamilyScores leaves some out: below)
    assert declared["required"] == (list(declared["properties"])[:4] if name == "familyScores" else list(printed))


def _json_path(path: str) -> str:
    return "$" + "".join(f"[{k}]" if k.isdigit() else f".{k}" for k in path.split("."))


@pytest.mark.parametrize("name,path", PARTS)
def test_an_extra_or_missing_key_in_a_nested_part_fails(name, path):
    first = SCHEMA["$defs"][name]["required"][0]
    for change, expected in (("extra", f"unexpected 'extra'"), ("missing", f"missing {first!r}")):
        report = _printed(every_part())
        part = _at(report, path)
        if change == "extra":
            part["extra"] = 1.0
        else:
            del part[first]
        found = errors(report, SCHEMA)
        where = _json_path(path)
        # a part printed `{}` when not made is an anyOf: the first option's complaint is quoted
        assert found in ([f"{where}: {expected}"], [f"{where}: matches no anyOf option ({where}: {expected})"]), found


def test_a_familys_hold_figures_come_together_or_not_at_all():
    report = _printed(every_part())
    drag = report["families"]["drag"]
    without = {k: v for k, v in drag.items() if not k.startswith("hold_")}
    assert errors({**report, "families": {"drag": without}}, SCHEMA) == []
    del drag["hold_cv_by_speed"]
    found = errors(report, SCHEMA)
    assert len(found) == 1 and "'hold_cv_speed_mps' without 'hold_cv_by_speed'" in found[0], found
