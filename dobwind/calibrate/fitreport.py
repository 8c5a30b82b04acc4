"""What `dobwind fit` shows a person: the text report of a fit and its figure (the fitted surface with
the calibration points and residuals, or the drag law). The fitting itself is in fit.py, fitfamily.py
and dragfit.py."""
from __future__ import annotations

import numpy as np

from dobwind.calibrate import dragfit
from dobwind.calibrate.fit import FOLDS, FitReport, Points
from dobwind.calibrate.reportparts import family_dict
from dobwind.model.airframe import Airframe
from dobwind.model.forceair import term_matrix
from dobwind.model.terms import parse_term
from dobwind.model.kinds import DragFrame


def _term_matrix(terms: list[str], m: np.ndarray, n: np.ndarray, fz: np.ndarray) -> np.ndarray:
    return term_matrix([parse_term(t) for t in terms], m, n, fz)


def _errors(cv: float | None, extrapolated: float | None) -> str:
    text = f"grouped {FOLDS}-fold CV " + ("n/a (one hold)" if cv is None else f"{cv:.3f} m/s{dragfit.diverged(cv)}")
    return text + ("" if extrapolated is None else f", top holds extrapolated {extrapolated:.3f} m/s")


def _zero_text(report: FitReport) -> str:
    """The score the vertical CV is judged against (fitfamily.vertical_warning), and the CV's share of it:
    the margin by which the vertical law beats publishing no vertical airflow at all."""
    zero, cv = report.vertical_zero_rmse_mps, report.vertical_cv_rmse_mps
    if zero is None:
        return ""
    share = f", the CV {cv / zero:.2f} of it" if cv is not None and zero > 0 else ""
    unexplained, se = report.vertical_unexplained_share, report.vertical_unexplained_share_se
    judged = ("" if unexplained is None or se is None else
              f"; unexplained share of the vertical mean square {unexplained:.2f}, standard error {se:.2f} over "
              "the CV blocks (the law is used when the share is below 1 by more than two)")
    return f"; zero vertical airflow scores {zero:.3f} m/s (RMS of the true vertical airflow){share}{judged}"


def _hold_line(report: FitReport, scored_s: float = 15.0) -> list[str]:
    """The hold-level CV, split into what a longer hold keeps and what averages out (dobwind/calibrate/holdcv.py),
    and what that means for a hold scored for ``scored_s`` (replay scores a 20 s hold for 15 s)."""
    table = report.hold_cv_by_speed
    if report.hold_cv_diverged:
        return [f"hold-level CV not measured: {report.hold_cv_diverged}"]
    if report.hold_cv_speed_mps is None or table is None or not table.bias_mps:
        return []
    from dobwind.calibrate.holdcv import HoldCV

    hold = HoldCV.from_table(report.hold_cv_speed_mps, table)
    speeds = table.speeds_mps
    longer = [hold.predicted(v, float("inf"), scored_s) for v in speeds]
    window = table.window_s
    return [f"hold-level CV {report.hold_cv_speed_mps:.3f} m/s (held-out holds scored "
            f"{'?' if window is None else f'{window:.1f}'} s); by airflow speed "
            + ", ".join(f"{v:.1f} m/s: {r:.3f} (bias {b:.3f})" for v, r, b in zip(speeds, table.rms_mps, table.bias_mps)),
            f"  expected on holds scored {scored_s:g} s: " + ", ".join(f"{v:.1f} m/s: {e:.3f}" for v, e in zip(speeds, longer))]


def _low_pass_line(report: FitReport) -> list[str]:
    """What the fit did to the low-pass at zero airflow (dobwind/calibrate/hovernoise.py), if anything."""
    change = report.low_pass
    if change is None:
        return []
    (f0, f1), (n0, n1) = change.cutoff_hz, change.still_noise_mps
    # After a kept blend the cutoff is the one the first fit chose (the blended fit is not lowered
    # further): the first figure is the airframe route's at its own cutoff, the second the blend's there.
    route = report.acceleration_route
    whose = " (of the blended fit)" if route is not None and route.kept else ""
    return [f"low-pass at zero airflow{whose} lowered {f0:.3g} -> {f1:.3g} Hz: noise at low airflow {n0:.3f} -> {n1:.3f} m/s "
            f"per horizontal axis (target {change.target_mps:g} m/s; --hover-noise)"]


def _route_line(report: FitReport) -> list[str]:
    """The noise at low airflow with the airframe's acceleration input and with it blended with the
    velocity's derivative (dobwind/calibrate/accelroute.py), when the fit compared them."""
    route = report.acceleration_route
    if route is None:
        return []
    before, after = route.still_noise_mps
    was, blend = route.bias_time_s
    if route.blend_passed is None:
        outcome = f"the blended fit failed ({route.blend_reasons[0]})"
    else:
        outcome = (("no low-airflow segment" if after is None else f"{after:.3f} m/s")
                   + ("" if route.blend_passed else ", self-check failed"))
    head = "blended" if route.kept else "not blended"
    return [f"acceleration {head}: noise at low airflow {before:.3f} m/s per axis with acceleration = "
            f"\"{route.acceleration}\" (acceleration_bias_time {was:g} s); with acceleration_bias_time "
            f"{blend:g} s, the low frequencies from the velocity, {outcome}"]


def _exponent_line(report: FitReport) -> list[str]:
    if len(report.exponent_scores) < 2:
        return []
    tried = ", ".join(f"{p} {s:.3f}" for p, s in report.exponent_scores.items())
    exponent = report.drag.get("exponent", 2.0)
    # Scores made of clipped predictions (hold_cv_diverged) tie or differ by the clip, not by the law.
    ranked = ("" if not report.hold_cv_diverged else
              " (the chosen law's held-out predictions diverged, hold-level CV above: these scores rank nothing)")
    return [f"  exponent {exponent:g}, chosen by the hold-level score (CV and top holds, m/s) of each tried: {tried}{ranked}"]


# The drag law's coefficients (docs/formats.md, [force_air]): printed once under the law so that no
# figure of the report stands without its unit.
DRAG_UNITS = ("l0, l2c, l2s, lr, lz, i1 in N/(m/s); q0, q2c, q2s, q1c, q4c, q4s, qax, qay, qax1c, qay1c in N/(m/s)^exponent; qz, i2 in "
              "N/(m/s)^2; ox, oy in N; kappa a share of the thrust (no unit)")


def runs_lines(report: FitReport) -> list[str]:
    """Per calibration log: the mean airflow error the law leaves and whether it looks like an outlier."""
    if not report.runs:
        return []
    how = ("the law fitted on the logs' means, each weighted once (bisquare weights); the families ranked by "
           "the robust loss of these errors (run_loss)" if report.anchored else "the law fitted on every sample")
    lines = [f"  per log ({how}): mean airflow against the wind truth (per log below), error of the mean estimated airflow, weight"]
    for run in report.runs:
        mark = "  OUTLIER: disagrees with the other logs" if run.outlier else ""
        lines.append(f"    {run.log}: {run.mean_speed_mps:.2f} m/s, error {run.error_mps:.2f} m/s, "
                     f"weight {run.weight:.2f}{mark}")
    return lines


def text_report(report: FitReport) -> str:
    def model(terms: list[str], coefs: list[float]) -> str:
        return " + ".join(f"{c:.4g}*{t}" if t != "1" else f"{c:.4g}" for t, c in zip(terms, coefs))

    vertical = ("kept from the airframe" if report.vertical_rmse_mps is None else
                f"RMSE {report.vertical_rmse_mps:.3f} m/s, "
                + _errors(report.vertical_cv_rmse_mps, report.vertical_extrapolation_rmse_mps) + _zero_text(report))
    # Every printed figure of each family, in the order --json prints them (reportparts.family_dict).
    families = [f"family {name}: " + ", ".join(f"{k} {'n/a' if v is None else f'{v:.3f}'}"
                                              for k, v in family_dict(scores).items() if v is None or isinstance(v, float))
                for name, scores in report.families.items()]
    chosen = ([f"model: {report.model} (chosen by grouped CV and extrapolation of the airflow; a tie within 2 % "
               "goes to drag-body, else to a hold-level score 2 % better)"] + families
              + _hold_line(report) + _low_pass_line(report) + _route_line(report))
    if report.drag:  # either drag family (heading or body frame)
        law = ", ".join(f"{k} {v:.4g}" for k, v in report.drag.items())
        return "\n".join(chosen + [
            f"{report.samples} samples; thrust scale {report.thrust_scale:.4f}; force offset "
            f"[{', '.join(f'{v:.3f}' for v in report.force_offset_n)}] N",
            f"drag law: {law}",
            f"  units: {DRAG_UNITS}",
            *(f"  not chosen: {where}" for where in report.not_increasing),
            *_exponent_line(report),
            *runs_lines(report),
            f"  horizontal airflow RMSE {report.horizontal_rmse_mps:.3f} m/s, "
            + _errors(report.horizontal_cv_rmse_mps, report.horizontal_extrapolation_rmse_mps),
            f"  vertical airflow RMSE {report.vertical_rmse_mps:.3f} m/s, "
            + _errors(report.vertical_cv_rmse_mps, report.vertical_extrapolation_rmse_mps) + _zero_text(report)])
    return "\n".join(chosen + [
        f"calibration points {report.points} (2 s means of steady flight; {report.outliers_removed} outliers removed), "
        f"{report.zero_airflow_points} at zero airflow; {report.directions} of 12 airflow directions, "
        f"{report.speeds} speeds",
        f"thrust scale {report.thrust_scale:.4f}; force offset [{', '.join(f'{v:.3f}' for v in report.force_offset_n)}] N",
        f"horizontal speed = {model(report.horizontal_terms, report.horizontal_coefficients)}",
        f"  RMSE {report.horizontal_rmse_mps:.3f} m/s, "
        + _errors(report.horizontal_cv_rmse_mps, report.horizontal_extrapolation_rmse_mps),
        f"vertical (down) = {model(report.vertical_terms, report.vertical_coefficients)}",
        f"  {vertical}",
    ])


def drag_plot(af: Airframe, path: str) -> None:
    """The fitted drag law: force along body x, y and z against airflow speed along that axis."""
    import matplotlib.pyplot as plt

    from dobwind.model.forceair import body_drag_force, drag_force
    from dobwind.io.plots import save

    assert af.drag is not None
    speed = np.linspace(0.0, 12.0, 121)
    zero = np.zeros_like(speed)
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for label, (vx, vy, vz), pick in (("x (forward)", (speed, zero, zero), 0), ("y (right)", (zero, speed, zero), 1),
                                      ("z (down)", (zero, zero, speed), 2)):
        # The body-frame law at hover thrust (rotor term 1); the heading-frame law of level flight.
        force = body_drag_force(af.drag, vx, vy, vz, 1.0, 1e-9) if af.drag.frame == DragFrame.BODY else drag_force(af.drag, vx, vy, vz)
        ax.plot(speed, force[pick] + zero, label=f"air along body {label}")
    ax.set_xlabel("relative airflow speed along the axis (m/s)")
    ax.set_ylabel("force (N)")
    ax.set_title(f"{af.name}: fitted drag law (force against airflow along each body axis)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    save(fig, path)


def fit_plot(af: Airframe, points: Points | None, path: str) -> None:
    """Fitted horizontal surface over the (m, n) force plane with the calibration points, and residuals."""
    import matplotlib.pyplot as plt

    from dobwind.io.plots import save

    if af.drag is not None or points is None:
        drag_plot(af, path)
        return

    fig, (surface, residual, vertical) = plt.subplots(1, 3, figsize=(16, 5), width_ratios=(1.25, 1, 1))
    span = max(float(np.max(np.abs(np.r_[points.m, points.n]))) * 1.1, 1e-3)
    grid = np.linspace(-span, span, 121)
    mm, nn = np.meshgrid(grid, grid)
    terms = list(af.horizontal.term_texts)
    values = _term_matrix(terms, mm.ravel(), nn.ravel(), np.zeros(mm.size)) @ np.asarray(af.horizontal.coefficients)
    contour = surface.contourf(mm, nn, np.maximum(values, 0).reshape(mm.shape), levels=20, cmap="viridis")
    fig.colorbar(contour, ax=surface, label="horizontal airflow speed (m/s)")
    # Thin dark edges: white ones hid the colour of small points, and the colour is the point's message.
    surface.scatter(points.m, points.n, c=points.speed_h, cmap="viridis", edgecolors="black", linewidths=0.3, s=18,
                    vmin=contour.get_clim()[0], vmax=contour.get_clim()[1])
    surface.set_xlabel("m: heading-frame x force, offset removed (N)")
    surface.set_ylabel("n: heading-frame y force (N)")
    surface.set_title("model surface; points: calibration truth, same colour scale", fontsize=10)
    surface.set_aspect("equal")
    predicted = _term_matrix(terms, points.m, points.n, points.fz) @ np.asarray(af.horizontal.coefficients)
    residual.scatter(points.speed_h, np.maximum(predicted, 0) - points.speed_h, s=10, alpha=0.7, color="#0072B2")
    residual.set_xlabel("true horizontal airflow speed (m/s)")
    residual.set_title("horizontal: model - truth", fontsize=10)
    # The vertical model is a function of the vertical airflow: its residuals belong on that axis.
    if af.vertical.terms:
        vpred = _term_matrix(list(af.vertical.term_texts), points.m, points.n, points.fz) @ np.asarray(af.vertical.coefficients)
        vertical.scatter(-points.air_z, -(vpred - points.air_z), s=10, alpha=0.7, color="#D55E00")
    vertical.set_xlabel("true vertical airflow, up (m/s)")
    vertical.set_title("vertical: model - truth (up)", fontsize=10)
    for ax in (residual, vertical):
        ax.axhline(0, color="black", lw=0.8)
        ax.set_ylabel("residual (m/s)")
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"{af.name}: force-air fit ({len(points.m)} calibration points, {af.force_air_model} model)")
    fig.tight_layout()
    save(fig, path)
