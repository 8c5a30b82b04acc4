"""`dobwind demo`: the pipeline on the reference airframe, end to end, as far as it exists.

check -> analyze (plots) -> generate -> verify (both precisions) -> reference speed. Calibration,
simulation and replay join when they land (see the README's roadmap).
"""
from __future__ import annotations

import time
from pathlib import Path


from dobwind.analysis.report import analyze, write_plots
from dobwind.codegen.generate import generate_to_dir
from dobwind.harness.verify import verify_airframe
from dobwind.model import reference
from dobwind.model.airframe import load_airframe
from dobwind.model.exercise import flight_inputs
from dobwind.model.step import build_step

REFERENCE_AIRFRAME = Path(__file__).resolve().parents[1] / "airframes" / "m300.toml"


def run_demo(out_dir: str) -> int:
    out = Path(out_dir)
    af = load_airframe(REFERENCE_AIRFRAME)
    model = build_step(af)
    print(f"== airframe {af.name}: {af.mass_kg} kg, {af.thrust.rotors} rotors, {af.observer.discretization} observer, "
          f"{model.step.n_instructions()} CasADi instructions per step")

    report, systems = analyze(af, [0.1, 0.5, 1.0])
    plots = write_plots(report, systems, out / "analysis")
    obs, ramp = report["observer"][0], report["ramp"]
    at_half = next(g for g in obs["gain_phase"] if g["freq_hz"] == 0.5)
    print(f"== analyze: observer bandwidth {obs['bandwidth_hz']:.3f} Hz (paper: 0.5 Hz), at 0.5 Hz "
          f"{at_half['gain_db']:.2f} dB / {at_half['phase_deg']:.1f} deg; schedule "
          f"{'stable' if report['schedule']['stable'] else 'UNSTABLE'}; ramp lag {ramp['lag_reduction_s']:.2f} s less "
          f"than a fixed {ramp['fixed_cutoff_hz']:g} Hz filter (paper: 2.2 s)")
    for path in plots:
        print(f"   plot: {path}")

    written = generate_to_dir(af, out / "c" / af.name, "single")
    print(f"== generate: {', '.join(p.name for p in written)} in {written[0].parent}")

    verification = verify_airframe(af, "both", steps=20000)
    print("== " + verification.text().replace("\n", "\n   "))

    rows = flight_inputs(model, 100_000, seed=3)
    rolled = reference.rolled_step(model)
    start = time.perf_counter()
    reference.run(model, rows, rolled=rolled)
    elapsed = time.perf_counter() - start
    print(f"== Python reference: 100,000 samples in {elapsed:.2f} s ({elapsed / 1e5 * 1e6:.1f} us per sample)")
    print("== not yet in the demo: simulate, fit, replay (calibration and replay issue)")
    return 0 if verification.passed and report["stable"] else 1


