"""Refresh generated_c/<name>/ for the airframes in airframes/ whose C is checked in (`make regen`).

Only the reference airframe's code is checked in; to check in another, generate it into
generated_c/<name>/ once and regen keeps it current from then on."""
from __future__ import annotations

import sys
from pathlib import Path

from dobwind.emit import generate_to_dir
from dobwind.model.airframe import load_airframe

ROOT = Path(__file__).resolve().parents[1]


def checked_in_airframes() -> list[Path]:
    return sorted((ROOT / "airframes").glob("*.toml"))


def main() -> int:
    for path in checked_in_airframes():
        af = load_airframe(path)
        if not (ROOT / "generated_c" / af.name).is_dir():
            continue
        for written in generate_to_dir(af, ROOT / "generated_c" / af.name, "single"):
            print(written.relative_to(ROOT))
    return 0


if __name__ == "__main__":
    sys.exit(main())
