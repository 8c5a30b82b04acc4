"""The integration pages docs/px4.md and docs/ardupilot.md show the files `generate --target` writes
for airframes/m300.toml, verbatim: each block follows a marker line `<!-- generated: PATH -->` (PATH as
in the generated folder). tests/test_autopilot_targets.py checks every block against the generator and
compiles the same files; after a change to the templates, refresh the pages with

    python -m dobwind.codegen.targetdocs
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

from dobwind.codegen.generate import generate_code
from dobwind.model.airframe import load_airframe
from dobwind.model.kinds import Precision

ROOT = Path(__file__).resolve().parents[1]
PAGES = {"px4": ROOT / "docs" / "px4.md", "ardupilot": ROOT / "docs" / "ardupilot.md"}
AIRFRAME = ROOT / "airframes" / "m300.toml"
# A marker, then a fenced block of any language: group 1 the path, group 2 the fence's opening line.
BLOCK = re.compile(r"<!-- generated: (\S+) -->\n(```\w*\n)(.*?)```\n", re.S)


def generated_files(target: str) -> dict[str, str]:
    return generate_code(load_airframe(AIRFRAME), Precision.SINGLE, target=target).files


def shown_blocks(text: str) -> dict[str, str]:
    """Path -> the block's text as the page shows it."""
    return {m.group(1): m.group(3) for m in BLOCK.finditer(text)}


def refreshed(text: str, files: dict[str, str]) -> str:
    def replace(match: re.Match) -> str:
        body = files[match.group(1)]
        return f"<!-- generated: {match.group(1)} -->\n{match.group(2)}{body.rstrip(chr(10))}\n```\n"

    return BLOCK.sub(replace, text)


def main() -> int:
    for target, page in PAGES.items():
        text = page.read_text(encoding="utf-8")
        page.write_text(refreshed(text, generated_files(target)), encoding="utf-8")
        print(page)
    return 0


if __name__ == "__main__":
    sys.exit(main())
