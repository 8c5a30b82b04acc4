"""Each test module's seconds in a JUnit XML report, printed as tests/conftest.py's MODULE_SECONDS table.

Measure with a full run, serial or on workers (each test is timed in the process that runs it):
    .venv/bin/python -m pytest -q -p no:xdist --junitxml=out/suite.xml
    .venv/bin/python -m tools.module_seconds out/suite.xml
and paste the printed lines over the table. A module's seconds are the sum of its test cases' times
(pytest counts setup, call and teardown in each, so module-scoped fixtures land on their first test)."""
from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path


def module_of(classname: str) -> str | None:
    """``tests.test_codegen`` or ``tests.test_codegen.TestX`` -> ``test_codegen.py``; None outside tests/."""
    for part in classname.split("."):
        if part.startswith("test_"):
            return f"{part}.py"
    return None


def module_seconds(report: Path) -> dict[str, float]:
    """Module file name -> seconds, longest first."""
    totals: dict[str, float] = {}
    for case in ET.parse(report).getroot().iter("testcase"):
        module = module_of(case.get("classname", ""))
        if module is not None:
            totals[module] = totals.get(module, 0.0) + float(case.get("time", "0") or 0.0)
    return dict(sorted(totals.items(), key=lambda kv: (-kv[1], kv[0])))


def table_lines(seconds: dict[str, float], floor: float = 2.0) -> list[str]:
    """The table's body: modules of at least ``floor`` seconds (shorter ones keep collection order anyway)."""
    return [f'    "{name}": {value:.0f},' for name, value in seconds.items() if value >= floor]


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        sys.stderr.write("usage: python -m tools.module_seconds REPORT.xml\n")
        return 2
    report = Path(args[0])
    try:
        seconds = module_seconds(report)
    except (OSError, ET.ParseError) as exc:
        sys.stderr.write(f"module_seconds: {report}: not a readable JUnit XML report ({exc})\n")
        return 2
    print("\n".join(table_lines(seconds)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
