"""Autopilot integrations of the generated C (`dobwind generate --target px4|ardupilot`): a PX4
module folder and an ArduPilot library folder, rendered by the same Jinja templates as the C.

Each folder is self-contained: it holds copies of <name>_wind.c and <name>_wind.h beside the module
or library code, so an integrator copies one folder into the autopilot's tree (docs/px4.md,
docs/ardupilot.md). Output is deterministic, like the C's.
"""
from __future__ import annotations

from dataclasses import dataclass

from dobwind.codegen.printer import CPrinter
from dobwind.model.step import StepModel
from dobwind.model.kinds import Precision
from dobwind.model.signals import log_signals

TARGETS = ("px4", "ardupilot")
# The folder each target writes, inside generate's output folder.
TARGET_FOLDERS = {"px4": "px4", "ardupilot": "AP_DOBWind"}


@dataclass(frozen=True)
class MsgField:
    type: str
    name: str
    doc: str


def _msg_fields(model: StepModel) -> list[MsgField]:
    """The dob_wind message: every output of the step (its units in the comment) and the status."""
    fields = [MsgField("float32" if f.size == 1 else f"float32[{f.size}]", f.name, f"{f.doc} ({f.unit})")
              for f in model.outputs.fields]
    fields.append(MsgField("uint32", "status", "the step's status bits: 0 is a valid and trusted estimate"))
    return fields


def _context(model: StepModel, common: dict) -> dict:
    af = model.airframe
    printer = CPrinter(Precision.SINGLE)
    return {
        **common,
        "rpm": log_signals(af).rotor_speeds,
        "rotors": af.thrust.rotors if log_signals(af).rotor_speeds else 0,
        "acc_mode": af.observer.acceleration,
        "mass_g": printer.literal(af.mass_kg * af.gravity_mps2),
        "fields": _msg_fields(model),
    }


def render_target(target: str, env, model: StepModel, common: dict, c_files: dict[str, str]) -> dict[str, str]:
    """File name (relative to the output folder) -> text, for one target; ``c_files`` are the
    single-precision step's files, copied into the folder."""
    name = common["name"]
    folder = TARGET_FOLDERS[target]
    context = _context(model, common)
    if target == "px4":
        files = {
            "CMakeLists.txt": env.get_template("px4_CMakeLists.txt.j2").render(**context),
            "Kconfig": env.get_template("px4_Kconfig.j2").render(**context),
            "module.yaml": env.get_template("px4_module.yaml.j2").render(**context),
            "DobWind.hpp": env.get_template("px4_module.hpp.j2").render(**context),
            "DobWind.cpp": env.get_template("px4_module.cpp.j2").render(**context),
            "msg/DobWind.msg": env.get_template("px4_DobWind.msg.j2").render(**context),
        }
    elif target == "ardupilot":
        files = {
            "AP_DOBWind.h": env.get_template("ardupilot_AP_DOBWind.h.j2").render(**context),
            "AP_DOBWind.cpp": env.get_template("ardupilot_AP_DOBWind.cpp.j2").render(**context),
            "LogStructure.h": env.get_template("ardupilot_LogStructure.h.j2").render(**context),
            # ArduPilot's waf builds a library's .cpp files: the step compiles as C++ (it is C++-clean).
            f"{name}_wind_step.cpp": env.get_template("ardupilot_step.cpp.j2").render(**context),
        }
    else:
        raise ValueError(f"unknown target {target!r}")
    for copied in (f"{name}_wind.c", f"{name}_wind.h"):
        files[copied] = c_files[copied]
    return {f"{folder}/{path}": text for path, text in files.items()}
