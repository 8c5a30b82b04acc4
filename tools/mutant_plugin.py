"""pytest plugin (``-p tools.mutant_plugin``) that applies one model mutant before any test
module is imported: the target module's source is patched in memory and executed again in the same
module object, so every later ``from module import name`` sees the mutant.

The mutant comes as JSON in DOBWIND_MUTANT ({"module", "old", "new"}); the plugin writes "applied" to
the file named by DOBWIND_MUTANT_APPLIED, so the runner can tell a caught mutant from one that never ran.
"""
from __future__ import annotations

import importlib
import json
import os
from pathlib import Path


def _apply() -> None:
    spec = json.loads(os.environ["DOBWIND_MUTANT"])
    module = importlib.import_module(spec["module"])
    path = Path(module.__file__)
    source = path.read_text()
    if source.count(spec["old"]) != 1:
        raise RuntimeError(f"mutant anchor found {source.count(spec['old'])} times in {path}: {spec['old']!r}")
    exec(compile(source.replace(spec["old"], spec["new"]), str(path), "exec"), module.__dict__)
    Path(os.environ["DOBWIND_MUTANT_APPLIED"]).write_text("applied")


if os.environ.get("DOBWIND_MUTANT"):
    _apply()
