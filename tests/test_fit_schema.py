"""`fit --json` against its declared schema (docs/schemas/fit-report.schema.json, issue #34): real fit
reports of both families validate, the schema names every FitReport field in its order, and a renamed
or retyped field fails. The validator below covers the subset of JSON Schema the file uses (type,
enum, properties, required, additionalProperties, items, minItems/maxItems, anyOf, $ref to $defs):
jsonschema is not a dependency of the project."""
from __future__ import annotations

import contextlib
import copy
import dataclasses
import io
import json
from typing import Any

import pytest

from dobwind.calibrate.fit import FitReport
from dobwind.cli.app import main
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


@pytest.mark.parametrize("model", ["auto", "polynomial"])
def test_real_fit_reports_match_the_schema(reports, model):
    report = reports[model]
    assert errors(report, SCHEMA) == []
    assert (model == "auto" or report["model"] == "polynomial") and report["self_check"]["logs"]


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
    assert errors("drag-heading", {"type": "string", "enum": ["drag"]}) == ["$: 'drag-heading' not in ['drag']"]


def test_the_report_is_frozen_and_its_dict_a_copy():
    report = FitReport(warnings=["a"], runs=[{"log": "x.csv"}])
    with pytest.raises(dataclasses.FrozenInstanceError):
        report.points = 3  # type: ignore[misc]
    document = report.as_dict()
    document["warnings"].append("b")
    document["runs"][0]["log"] = "y.csv"
    assert report.warnings == ["a"] and report.runs == [{"log": "x.csv"}]
