"""`dobwind profile AIRFRAME LOG... -o PROFILE.nc|.csv [--bin M] [--plot PNG] [--jobs N]`: the command
around dobwind/atmos/profile.py: logs to workers, the per-bin sums combined, the table written and drawn."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from dobwind.cli.common import add_backend_options, AIRFRAME_HELP, JSON_HELP, Command, add_many_options
from dobwind.io import cfnames
from dobwind.cli.campaign import Done, expand_logs, format_table, run_all
from dobwind.core.errors import InputError
from dobwind.io.netcdf import is_netcdf
from dobwind.io.outputs import PNG, OutputFiles, Target, check_targets
from dobwind.atmos.profile import (BIN, DEFAULT_MIN_SECONDS, MIN_SECONDS, allowed_mask, combine, coverage,
                                   flight_sums, table)
from dobwind.core.progress import wanted
from dobwind.model.kinds import Precision

CSV_COLUMNS = ("height_bottom_m", "height_top_m", "height_m", "count", "speed_mean_mps", "speed_std_mps",
               "vector_speed_mps", "direction_from_deg", "direction_spread_deg", "northward_mean_mps",
               "eastward_mean_mps", "up_mean_mps", "up_std_mps", "sigma_h_mps", "sigma_up_mps",
               # how far each mean can be trusted (atmos/binstats.py), after the columns docs/atmospheric.md fixes
               "seconds", "n_eff", "speed_se_mps", "up_n_eff", "up_se_mps", "below_minimum")


def add(command: Command) -> None:
    p = command("profile", "wind speed, direction and vertical wind binned by height above take-off, over "
                "one or many flights")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("logs", nargs="+", help="flight logs (autopilot logs with global position; CSV logs with "
                   "lat, lon, alt columns, else height from vel_d) or folders of them")
    p.add_argument("-o", "--output", required=True, help="the profile to write: .csv or CF-NetCDF .nc (required)")
    p.add_argument("--bin", type=BIN, default=5.0, metavar="M", help=f"height bin, m ({BIN.text()}; default 5)")
    p.add_argument("--min-seconds", type=MIN_SECONDS, default=DEFAULT_MIN_SECONDS, metavar="S",
                   help=f"the data a bin needs for a mean, seconds of trusted rows over all flights "
                   f"({MIN_SECONDS.text()}; default {DEFAULT_MIN_SECONDS:g}; 0: none): a bin with less prints '-' "
                   "and says why, and its means are NaN in the output")
    p.add_argument("--plot", help="PNG of speed, direction and vertical wind against height with wind barbs "
                   "(default: none, not drawn)")
    p.add_argument("--allow", action="append", metavar="FLAG",
                   help="also use rows carrying this quality flag (e.g. extrapolated; repeatable; default: none, "
                   "status 0 rows only)")
    add_backend_options(p)
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    add_many_options(p, "profile")
    p.set_defaults(func=run)


def _job(airframe: str, log: str, bin_m: float, backend: str, precision: Precision, rate: float | None,
         allow: int) -> Done:
    try:
        return Done(log, flight_sums(airframe, log, bin_m, backend, precision, rate, allow))
    except InputError as exc:
        return Done(log, None, f"dobwind profile: {exc}", 2)
    except Exception as exc:  # noqa: BLE001 - a bug on one log must not lose the others' profile
        return Done(log, None, f"dobwind profile: internal error on {log}: {type(exc).__name__}: {exc}", 1)


def run(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe

    logs = expand_logs(args.logs)
    targets = [Target("-o", args.output)] + ([Target("--plot", args.plot, suffixes=PNG)] if args.plot else [])
    check_targets(targets, [args.airframe, *logs])
    if not str(args.output).lower().endswith(".csv") and not is_netcdf(args.output):
        raise InputError(f"-o {args.output}", None, "the profile is written as .csv or .nc (by its extension)")
    if is_netcdf(args.output):
        from dobwind.io.netcdf import require_xarray

        require_xarray(args.output)
    allow = allowed_mask(args.allow or [])
    af = load_airframe(args.airframe)
    import dobwind.replay.replay  # noqa: F401 - imported once here, inherited by every forked worker
    done = run_all(_job, [(args.airframe, log, args.bin, args.backend, args.precision, args.rate, allow) for log in logs],
                   logs, args.jobs, "profile", wanted(args.json))
    for result in done:
        if result.error:
            sys.stderr.write(result.error + "\n")
    good = [r for r in done if r.value is not None]
    stats = table(combine([r.value[0] for r in good]), args.bin, args.min_seconds)
    if not stats and not good:
        return max(r.code for r in done)  # each log's reason is on stderr already: nothing written
    if not stats:
        where = ", ".join(logs[:3]) + (" ..." if len(logs) > 3 else "")
        # Not when --allow uncalibrated was given: then UNCALIBRATED kept no row out, the other flags did.
        prior = (f"{args.airframe} is an uncalibrated prior, so every estimate carries UNCALIBRATED: calibrate it "
                 "with `dobwind fit`, or --allow uncalibrated for a rough profile"
                 if af.uncalibrated and not allow & allowed_mask(["uncalibrated"]) else "")
        why = "; ".join([prior] * bool(prior) + _reasons(good)) or "--allow admits quality-flagged rows"
        raise InputError(where, None, f"no trusted estimate with a height in any log: nothing written ({why})")
    span = coverage([r.value[3] for r in good])
    with OutputFiles(targets) as out:
        staged = out.stage(args.output)
        if is_netcdf(args.output):
            _write_netcdf(staged, stats, args, af, logs, span, _utc_seconds([r.value[3] for r in good]))
        else:
            _write_csv(staged, stats, args, af, span)
        if args.plot:
            from dobwind.atmos.profileplot import profile_plot

            profile_plot(stats, f"{af.name}: wind profile over {len(good)} flight(s)", str(out.stage(args.plot)))
    if args.json:
        from dobwind.io.jsonout import print_json

        print_json({**_as_json(stats, done, args), "time_coverage_utc": list(span) if span else None})
    else:
        print(_text(stats, done, kept_rows(args.allow), args.min_seconds))
    return max(r.code for r in done)


def _reasons(good: list[Done]) -> list[str]:
    """Each log's own reason for giving no row (atmos/profile.py why_no_row), named by the log."""
    return [f"{Path(r.log).name}: {n.removeprefix('no row: ')}" for r in good for n in r.value[2] if n.startswith("no row: ")]


def _as_json(stats: dict[str, np.ndarray], done: list[Done], args: argparse.Namespace) -> dict:
    # NaN (no spread from one sample, an unknown sigma) becomes null through print_json, which lists where.
    bins = [{c: stats[c][k].item() for c in CSV_COLUMNS} for k in range(len(stats["count"]))]  # below_minimum: bool
    logs = [{"log": r.log, "exit": r.code, "error": r.error,
             "trusted_rows": None if r.value is None else r.value[1],
             "notes": [] if r.value is None else list(r.value[2])} for r in done]
    return {"airframe_file": str(args.airframe), "output": str(args.output), "bin_m": args.bin,
            "min_seconds": args.min_seconds, "bins": bins, "logs": logs}


def kept_rows(allow: list[str] | None) -> str:
    """What the profile's rows are: "trusted rows" only without --allow; with it, say which flags got in
    (an UNCALIBRATED row is not trusted, and the output must not call it so)."""
    if not allow:
        return "trusted rows"
    return f"rows trusted or flagged only {'/'.join(sorted({a.strip().upper() for a in allow}))} (--allow)"


def _text(stats: dict[str, np.ndarray], done: list[Done], kept: str = "trusted rows", min_seconds: float = 0.0) -> str:
    rows = []
    for k in range(len(stats["count"])):
        # An empty bin, a bin under the minimum, a bin of one sample (no spread) or of calm samples (no
        # direction) prints '-', not nan; a bin under the minimum says why in the last column.
        rows.append([f"{stats['height_bottom_m'][k]:g} .. {stats['height_top_m'][k]:g}", str(stats["count"][k]),
                     _or_dash(stats['seconds'][k], 1), _or_dash(stats['n_eff'][k], 1),
                     _or_dash(stats['speed_mean_mps'][k]), _or_dash(stats['speed_std_mps'][k]),
                     _or_dash(stats['speed_se_mps'][k]),
                     _or_dash(stats['direction_from_deg'][k], 0), _or_dash(stats['direction_spread_deg'][k], 0),
                     _signed_or_dash(stats['up_mean_mps'][k]), _or_dash(stats['sigma_h_mps'][k]),
                     _why_no_mean(stats, k, min_seconds)])
    flights = [f"{r.log}: {r.value[1]} {kept}" + "".join(f"; {n}" for n in r.value[2]) if r.value is not None
               else f"{r.log}: failed" for r in done]
    header = ["height m", "n", "time s", "N_eff", "speed m/s", "std m/s", "SE m/s", "from deg", "spread deg",
              "up m/s", "sigma_h m/s", "no mean"]
    legend = ("n: rows; time s: the time the flights spent in the bin; N_eff: independent samples (from the rows' "
              "lag-1 autocorrelation about the bin's trend with height); SE: standard error of the mean speed (the "
              "scatter about that trend over sqrt(N_eff)); sigma_h: the "
              "model's 1-sigma of one row, a systematic term that does not average down")
    return "\n".join([format_table(header, rows), legend, *flights])


def _why_no_mean(stats: dict[str, np.ndarray], k: int, min_seconds: float) -> str:
    """Why a bin prints no mean: empty, or less data than --min-seconds ('' for a bin with a mean)."""
    if not stats["below_minimum"][k]:
        return ""
    if stats["count"][k] == 0:
        return "empty"
    seconds = stats["seconds"][k]
    have = f"{seconds:.1f} s" if np.isfinite(seconds) else "unknown time"
    return f"{have} < --min-seconds {min_seconds:g}"


def _or_dash(value: float, digits: int = 2) -> str:
    """NaN (no sample, an unknown sigma, no vertical wind) as '-', not as a number."""
    return f"{value:.{digits}f}" if np.isfinite(value) else "-"


def _signed_or_dash(value: float) -> str:
    return f"{value:+.2f}" if np.isfinite(value) else "-"


def _write_csv(path: Path, stats: dict[str, np.ndarray], args: argparse.Namespace, af,
               span: tuple[str, str] | None) -> None:
    from dobwind.io.logs import write_csv

    formats = ["%.6g"] * len(CSV_COLUMNS)
    formats[CSV_COLUMNS.index("count")] = formats[CSV_COLUMNS.index("below_minimum")] = "%d"
    comments = [f"dobwind profile: airframe {af.name} ({Path(args.airframe).name}), bin {args.bin:g} m, "
                "height above the take-off point; " + (kept_rows(args.allow) if args.allow else "trusted rows only"),
                f"UTC {span[0]} to {span[1]}" if span else "no GPS time in the logs: UTC unknown",
                f"a bin with less than {args.min_seconds:g} s of data (--min-seconds) has below_minimum 1 and no "
                "mean (nan); speed_se_mps is the standard error of the mean, sigma_h_mps the model's 1-sigma of one row"]
    write_csv(path, list(CSV_COLUMNS), np.column_stack([stats[c] for c in CSV_COLUMNS]), formats, comments)


def _utc_seconds(spans: list[tuple[float, float] | None]) -> tuple[float, float] | None:
    """The first and last trusted row's Unix time over the flights with GPS time (None: none has)."""
    known = [s for s in spans if s is not None]
    return (min(s[0] for s in known), max(s[1] for s in known)) if known else None


def _write_netcdf(path: Path, stats: dict[str, np.ndarray], args: argparse.Namespace, af, logs: list[str],
                  span: tuple[str, str] | None, utc_s: tuple[float, float] | None = None) -> None:
    import xarray as xr

    from dobwind.io.netcdf import calibration_text, time_response_text, write_dataset
    from dobwind import __version__

    height_attrs = {"standard_name": "height", "units": "m", "positive": "up", "axis": "Z",
                    "long_name": "height above the take-off point (bin centre)", "bounds": "height_bnds"}
    data = {**_mean_variables(stats, utc_s is not None), **_error_variables(stats, args, _methods(utc_s is not None)[0])}
    data["height_bnds"] = (("height", "nv"), np.column_stack([stats["height_bottom_m"], stats["height_top_m"]]), {})
    coords = {"height": ("height", stats["height_m"], height_attrs)}
    if utc_s is not None:
        coords["time"] = ((), 0.5 * (utc_s[0] + utc_s[1]), TIME_ATTRS)
    ds = xr.Dataset(data, coords=coords)
    ds.attrs = {"Conventions": cfnames.CONVENTIONS, "title": f"dobwind wind profile: {af.name}",
                "source": f"dobwind {__version__} disturbance-observer wind estimates binned by height",
                "history": f"dobwind {__version__} profile, bin {args.bin:g} m, minimum {args.min_seconds:g} s of "
                           f"data per bin, {len(logs)} log(s)",
                "references": "dobwind docs/atmospheric.md", "dobwind_version": __version__,
                "dobwind_airframe": af.name, "dobwind_airframe_file": Path(args.airframe).name,
                "dobwind_airframe_sha256": af.content_sha256, "dobwind_calibration": calibration_text(af),
                "dobwind_time_response": time_response_text(af, args.rate),
                "dobwind_logs": ", ".join(Path(log).name for log in logs), "dobwind_bin_m": float(args.bin),
                "dobwind_min_seconds": float(args.min_seconds)}
    if span:
        ds.attrs.update(time_coverage_start=span[0], time_coverage_end=span[1])
    write_dataset(path, ds)


# Each bin value is a mean over the rows inside its height cell AND over the time the flight(s) spent there:
# CF 1.8 section 7.3 lists axes processed jointly together ("height: time: mean"). The name time needs a
# time coordinate for CF checkers (section 7.3.4 would allow the standard name alone, compliance-checker does
# not): a scalar one at the middle of the flights' UTC span. Without GPS time there is no reference date, so
# no time coordinate (see docs/atmospheric.md), and the words in parentheses say the mean is over time too.
WHERE = "over the rows of every flight inside the height cell"
MEAN = f"height: time: mean ({WHERE})"
SPREAD = f"height: time: standard_deviation (sample standard deviation, {WHERE})"
NO_UTC = "; no UTC in the logs, so no time coordinate, and the mean is over the time the flights spent there too"
TIME_ATTRS = {"standard_name": "time", "units": "seconds since 1970-01-01 00:00:00", "calendar": "standard",
              "long_name": "middle of the UTC span of the trusted rows (time_coverage_start to time_coverage_end); "
                           "each bin is a mean over its own rows' times within it"}


def _var(values, std: str | None, units: str, long: str, method: str | None, **extra) -> tuple:
    attrs = {"units": units, "long_name": long, **({"cell_methods": method} if method else {}), **extra}
    if std:
        attrs["standard_name"] = std
    return ("height", np.asarray(values, dtype=np.float64), attrs)


def _methods(utc: bool) -> tuple[str, str]:
    """cell_methods of the means and of the spreads: over height and time; without UTC, no axis time to name."""
    if utc:
        return MEAN, SPREAD
    return (f"height: mean ({WHERE}{NO_UTC})",
            f"height: standard_deviation (sample standard deviation, {WHERE}{NO_UTC})")


def _mean_variables(stats: dict[str, np.ndarray], utc: bool) -> dict[str, tuple]:
    """The bin means and spreads (NaN in a bin under --min-seconds), each pointing at its error variables."""
    mean, spread = _methods(utc)
    h_anc = {"ancillary_variables": "wind_speed_standard_error_of_mean effective_sample_size time_in_bin count "
                                    "below_minimum wind_speed_standard_error"}
    up_anc = {"ancillary_variables": "upward_air_velocity_standard_error_of_mean "
                                     "upward_air_velocity_effective_sample_size upward_air_velocity_standard_error"}
    return {
        "wind_speed": _var(stats["speed_mean_mps"], "wind_speed", "m s-1", "mean horizontal wind speed", mean,
                           **h_anc),
        "wind_speed_spread": _var(stats["speed_std_mps"], None, "m s-1", "standard deviation of the horizontal "
                                  "wind speed in the bin", spread),
        "wind_from_direction": _var(stats["direction_from_deg"], "wind_from_direction", "degree",
                                    "direction of the vector-mean wind (blowing from, clockwise from north)", mean),
        "wind_from_direction_spread": _var(stats["direction_spread_deg"], None, "degree",
                                           "circular standard deviation of the sample directions", spread),
        "eastward_wind": _var(stats["eastward_mean_mps"], "eastward_wind", "m s-1", "mean eastward wind", mean),
        "northward_wind": _var(stats["northward_mean_mps"], "northward_wind", "m s-1", "mean northward wind",
                                mean),
        "upward_air_velocity": _var(stats["up_mean_mps"], "upward_air_velocity", "m s-1", "mean vertical wind",
                                    mean, **up_anc),
        "upward_air_velocity_spread": _var(stats["up_std_mps"], None, "m s-1", "standard deviation of the "
                                           "vertical wind in the bin", spread),
    }


def _error_variables(stats: dict[str, np.ndarray], args: argparse.Namespace, mean: str) -> dict[str, tuple]:
    """How far each mean can be trusted: the random error of the mean (CF standard_error of the mean
    variable), the model's per-row sigma kept apart under its pre-existing name (a systematic term: no
    standard_error label, as it is not the error of the mean), the data behind each bin."""
    row_sigma = ("mean calibrated 1-sigma of ONE {} estimate row in the bin: the model's uncertainty, a "
                 "systematic term that does not average down over rows; not the standard error of the bin mean "
                 "(that is {}_standard_error_of_mean)")
    n_eff = ("effective number of independent {} samples in the bin: rows x (1 - r) / (1 + r), r the lag-1 "
             "autocorrelation of the rows about their straight line in height (AR(1)); the rows are correlated by the estimator's low-pass and by the air itself")
    below = np.asarray(stats["below_minimum"], np.int8)
    return {
        "wind_speed_standard_error_of_mean": _var(stats["speed_se_mps"], "wind_speed standard_error", "m s-1",
                                                  "standard error of the bin-mean wind speed, its random part: the "
                                                  "scatter of the rows about their straight line in height over "
                                                  "sqrt(effective_sample_size)", None),
        "upward_air_velocity_standard_error_of_mean": _var(
            stats["up_se_mps"], "upward_air_velocity standard_error", "m s-1", "standard error of the bin-mean "
            "vertical wind, its random part: the rows' scatter about their straight line in height over "
            "sqrt(upward_air_velocity_effective_sample_size)", None),
        "wind_speed_standard_error": _var(stats["sigma_h_mps"], None, "m s-1",
                                          row_sigma.format("horizontal", "wind_speed"), mean),
        "upward_air_velocity_standard_error": _var(stats["sigma_up_mps"], None, "m s-1",
                                                   row_sigma.format("vertical", "upward_air_velocity"), mean),
        "effective_sample_size": _var(stats["n_eff"], None, "1", n_eff.format("horizontal wind speed"), None),
        "upward_air_velocity_effective_sample_size": _var(stats["up_n_eff"], None, "1",
                                                          n_eff.format("vertical wind"), None),
        "time_in_bin": _var(stats["seconds"], None, "s", "time the flights spent in the bin: rows x their "
                            "sampling interval, all flights together", None),
        "count": ("height", stats["count"].astype(np.int32),
                  {"standard_name": "number_of_observations", "units": "1",
                   "long_name": f"estimate rows in the bin ({kept_rows(args.allow)})"}),
        "below_minimum": ("height", below, {"long_name": f"1: less than {args.min_seconds:g} s of data in the bin "
                                            "(--min-seconds) or no row, so no mean is given",
                                            "flag_values": np.array([0, 1], np.int8),
                                            "flag_meanings": "mean_given below_minimum_time"}),
    }
