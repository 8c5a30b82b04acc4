"""Refresh generated_c/<name>/ for the shipped airframes whose C is checked in (`make regen`).

Only the reference airframe's code is checked in; to check in another, generate it into
generated_c/<name>/ once and regen keeps it current from then on. The airframes come from the package
(importlib.resources); generated_c/ is a folder of the checkout, found from the working directory or
the ROOT argument: `python -m tools.regen [ROOT]`."""
from __future__ import annotations

import sys
from pathlib import Path

from dobwind.generate.emit import generate_to_dir
from dobwind.model.airframe import load_airframe
from dobwind.core.resources import shipped_airframe, shipped_airframe_names


def checked_in_airframes() -> list[Path]:
    return [shipped_airframe(name) for name in shipped_airframe_names()]


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    root = Path(args[0]).resolve() if args else Path.cwd()
    if not (root / "generated_c").is_dir():
        sys.stderr.write(f"regen: {root / 'generated_c'}: no such folder (run at the checkout's root)\n")
        return 2
    for path in checked_in_airframes():
        af = load_airframe(path)
        if not (root / "generated_c" / af.name).is_dir():
            continue
        for written in generate_to_dir(af, root / "generated_c" / af.name, "single"):
            print(Path(written).relative_to(root))
    return 0


if __name__ == "__main__":
    sys.exit(main())
