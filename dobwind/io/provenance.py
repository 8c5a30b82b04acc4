"""How an airframe file says it was calibrated: the comment lines `fit` writes at its top when it
calibrates from autopilot logs (dobwind/calibrate/fieldfit.py), read back for `replay --json`'s
`calibration` (docs/field-logs.md). One module writes and reads them, so the two cannot drift apart.

The [calibration] table itself is the loader's (model/airframe.py): status "prior" is `dobwind init`'s
starter law (every estimate then carries the UNCALIBRATED status bit), "calibrated" (the default) is
everything else; the [envelope] table is written by `fit` only."""
from __future__ import annotations

from pathlib import Path

from dobwind.model.airframe import Airframe

FIT_PREFIX = "calibrated by `dobwind fit` from "
TRUTH_PREFIX = "wind truth: "


def provenance(log_paths: list[str], truth_text: str) -> list[str]:
    """The airframe's comment lines recording how it was calibrated (without the leading '# ')."""
    return [FIT_PREFIX + ", ".join(log_paths), TRUTH_PREFIX + truth_text]


def leading_comments(text: str) -> list[str]:
    """The comment lines before the first line of TOML, without their '#' (where fit puts its record)."""
    out = []
    for line in text.splitlines():
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            break
        if stripped:
            out.append(stripped.lstrip("#").strip())
    return out


def read_provenance(text: str) -> tuple[str | None, str | None]:
    """(the logs fit calibrated from, the wind truth it used) as the file's top comment records them;
    None for what it does not record (a hand-written file, `init`'s prior, a fit on CSV logs)."""
    lines = leading_comments(text)
    logs = next((line[len(FIT_PREFIX):] for line in lines if line.startswith(FIT_PREFIX)), None)
    truth = next((line[len(TRUTH_PREFIX):] for line in lines if line.startswith(TRUTH_PREFIX)), None)
    return logs, truth


def calibration_record(af: Airframe, path: str) -> dict:
    """`replay --json`'s `calibration`: whether the airframe was calibrated and, as far as its file
    records it, by what (fields in docs/field-logs.md)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        text = ""  # the loader has read it already; a file gone since only loses its comments
    logs, truth = read_provenance(text)
    return {"status": af.calibration, "uncalibrated": af.uncalibrated,
            "fitted_by_dobwind": af.envelope is not None, "calibrated_from": logs, "wind_truth": truth}
