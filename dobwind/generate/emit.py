"""Writes a generated C folder for the user: rendered by ``codegen``, swapped into place as a whole."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from dobwind.io.atomic import write_text_atomically
from dobwind.codegen.generate import generate_code, is_generated_name
from dobwind.model.airframe import Airframe
from dobwind.io.outputs import Target, check_replaceable, staged_folder
from dobwind.model.kinds import Precision


def generate_to_dir(af: Airframe, out_dir: str | Path, precision: Precision = Precision.SINGLE, option: str = "-o",
                    source: str | None = None, integration: str | None = None,
                    gate: Callable[[Path], None] | None = None) -> list[Path]:
    """Renders everything, then replaces ``out_dir`` as a whole (a sibling folder swapped in), so a
    full disk or a signal leaves either the old folder or the new one, never a mix. ``integration``:
    "px4" or "ardupilot" adds that autopilot's folder (codegen/targets.py). ``gate`` checks the
    rendered folder before the swap (generate's self-test): if it raises, nothing is written."""
    target = Target(option, str(out_dir), "dir")
    check_replaceable(target, is_generated_name)
    with staged_folder(target) as work:  # the render runs inside: a signal then removes the folder too
        code = generate_code(af, precision, source=source, target=integration)
        for name, text in code.files.items():
            (work / name).parent.mkdir(parents=True, exist_ok=True)  # a --target folder
            write_text_atomically(work / name, lambda handle, text=text: handle.write(text))
        if gate is not None:
            gate(work)
    return [Path(out_dir) / name for name in code.files]
