"""A measurement, not a fix: an ArduCopter log read with the autopilot's air-density compensation undone.

ArduCopter divides its throttle by the air density ratio (AP_Motors' compensation gain) and takes that ratio
from AP_Baro::get_EAS2TAS, which recomputes it only when the baro altitude has moved 25 m since its last
computation: ratio = (pressure / (287.26 x (ground temperature + 273.15 - 0.0065 x altitude))) / 1.225.
In the field SITL log the ratio in force is 1 until BARO.Alt first crosses 25 m; then CTUN.ThO steps down
by 0.90 while the motors' outputs stay, so ThO / ThH x m g (dobwind's collective thrust, ThH learned
before) reports 0.90 of the thrust for the rest of the flight. This module reconstructs the ratio from BARO
and runs one dobwind command in this process with the thrust column multiplied by (ratio when ThH was
learned: 1) / (ratio now), to measure what the step costs (docs/field-calibration.md, "The SITL stand-in"):

    .venv/bin/python -m benchmarks.densitycomp fit START.toml LOG --truth sitl -o FIT.toml
    .venv/bin/python -m benchmarks.densitycomp replay FIT.toml LOG -o EST.csv
"""
from __future__ import annotations

import sys
from typing import Any

import numpy as np

import dobwind.io.dataflash as dataflash

RECOMPUTE_M = 25.0       # AP_Baro: the altitude change that makes get_EAS2TAS recompute
SEA_LEVEL_DENSITY = 1.225
GAS_CONSTANT = 287.26    # ArduPilot's ISA_GAS_CONSTANT
LAPSE_RATE = 0.0065      # K/m, ArduPilot's ISA_LAPSE_RATE


def density_ratio(alt_m: np.ndarray, pressure_pa: np.ndarray, ground_temp_c: np.ndarray, initial: float = 1.0) -> np.ndarray:
    """The ratio ArduCopter's motors use at each BARO sample: held until the altitude has moved 25 m from
    where it was last computed (the first computation at the first 25 m from zero; before it ``initial``)."""
    out = np.empty(len(alt_m))
    current, last = initial, 0.0
    for k, alt in enumerate(alt_m):
        if abs(alt - last) >= RECOMPUTE_M:
            temp_k = ground_temp_c[k] + 273.15 - LAPSE_RATE * alt
            current, last = pressure_pa[k] / (GAS_CONSTANT * temp_k) / SEA_LEVEL_DENSITY, float(alt)
        out[k] = current
    return out


def _baro(path: str) -> tuple[np.ndarray, np.ndarray]:
    rows = [r for r in dataflash.load_messages(path, ("BARO",))["BARO"] if r.get("I", 0) == 0]
    t = np.array([r["TimeUS"] * 1e-6 for r in rows])
    ratio = density_ratio(np.array([r["Alt"] for r in rows]), np.array([r["Press"] for r in rows]),
                          np.array([r["GndTemp"] for r in rows]))
    return t, ratio


def undo_compensation() -> None:
    """Patch dobwind's DataFlash reader, in this process only: its collective thrust divided by the ratio."""
    original_columns, original_read = dataflash._columns, dataflash.read_dataflash

    def read(path: str, *args: Any, **kwargs: Any) -> Any:
        t, ratio = _baro(path)

        def columns(*a: Any) -> dict:   # dataflash._columns(af, vel, att, imu, psc, escs, ctun, msgs, clock, notes)
            cols = original_columns(*a)
            clock, notes = a[8], a[9]
            if "thrust" in cols:
                k = np.clip(np.searchsorted(t, clock, side="right") - 1, 0, len(t) - 1)
                cols["thrust"] = cols["thrust"] / ratio[k]
                notes.append("benchmarks.densitycomp: thrust divided by ArduCopter's density ratio "
                             f"({', '.join(f'{r:.4f}' for r in sorted(set(ratio.tolist())))})")
            return cols

        dataflash._columns = columns
        try:
            return original_read(path, *args, **kwargs)
        finally:
            dataflash._columns = original_columns

    dataflash.read_dataflash = read


def main(argv: list[str] | None = None) -> int:
    undo_compensation()
    from dobwind.cli.app import main as dobwind

    return dobwind(sys.argv[1:] if argv is None else argv)


if __name__ == "__main__":
    raise SystemExit(main())
