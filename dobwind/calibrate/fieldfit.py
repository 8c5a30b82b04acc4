"""`fit`'s options for logs without wind columns (issue #36): which truth (--wind, --truth), checked, and
how it reaches the one fit pipeline (a log reader, fitfamily.fit_airframe's ``log_reader``) and the
written airframe (its provenance comment)."""
from __future__ import annotations

import argparse
from dataclasses import dataclass, field

from dobwind.core.errors import InputError
from dobwind.calibrate.directionshape import DirectionShape
from dobwind.calibrate.fieldtruth import LogReader, PerLogWind, Truth, flight_of, parse_wind, read_truth_csv, truth_reader
from dobwind.io.provenance import provenance
from dobwind.model.airframe import Airframe
from dobwind.core.options import Bound

UNKNOWN = "unknown"
SITL = "sitl"


@dataclass(frozen=True)
class FieldOptions:
    wind: tuple[str, ...]   # --wind (repeatable): SPEED@FROM[,UP] once or once per log, or "unknown"
    truth: str | None       # --truth: FILE.csv or "sitl"
    rate_hz: float | None   # --rate: resample autopilot logs at this rate
    segment_s: float | None  # --segment-s: one unknown wind per this many seconds
    still_air: bool = False

    @property
    def given(self) -> bool:
        return bool(self.wind) or self.truth is not None

    def files(self) -> list[str]:
        """Input files the options name (a truth file), for the output checks."""
        return [self.truth] if self.truth is not None and self.truth != SITL else []


@dataclass(frozen=True)
class FieldTruth:
    """The truth chosen, the reader the fit calls, and what to tell the user."""
    truth: Truth
    reader: LogReader
    summary: list[str] = field(default_factory=list)   # printed with the fit report (the winds found)
    # The drag law's direction shape where the flight does not identify it: the simulator's for a SITL log.
    direction_shape: DirectionShape | None = None

    def warnings(self) -> list[str]:
        return list(getattr(self.truth, "warnings", []))

    def header(self, log_paths: list[str]) -> str:
        """The written airframe's provenance comment (TOML comment lines)."""
        return "".join(f"# {line}\n" for line in provenance(log_paths, self.truth.describe()))

    def record(self, log_paths: list[str]) -> dict:
        """The truth for --json, with what it gave each log."""
        return {"truth": self.truth.describe(), "summary": self.summary,
                "per_log": {path: self.truth.describe_log(path) for path in log_paths}}


COLUMNS_TRUTH = ("its own wind_n/wind_e/wind_d columns (a known wind: a tunnel run's set wind, a simulator's, "
                 "or one measured beside the flight)")
STILL_AIR_TRUTH = "zero wind (--still-air): the airflow is the vehicle's own motion"


def truth_lines(field: FieldTruth | None, log_paths: list[str], still_air: bool) -> list[str]:
    """fit's text lines naming, per log, the wind its airflow was computed against: the log's columns,
    still air, or the --wind/--truth source (an estimated wind says so, and where it was identified)."""
    lines = ["wind truth per log (the airflow above is this wind minus the ground velocity):"]
    for path in log_paths:
        said = field.truth.describe_log(path) if field else STILL_AIR_TRUTH if still_air else COLUMNS_TRUTH
        lines.append(f"  {path}: {said}")
    if field is not None and getattr(field.truth, "ESTIMATED", False):
        lines.append(ESTIMATED_SELF_CHECK)
    return lines


# With --wind unknown the self-check's "true" wind is the estimate itself: say what a PASS then means.
ESTIMATED_SELF_CHECK = ("  (the self-check below compares with these estimated winds, not with an independent truth: a "
                        "PASS says the law and the winds agree; their 1-sigma is the statistical part of their error, a misfit "
                        "of the law adds a bias it does not show)")


def check_options(options: FieldOptions, logs: int) -> None:
    if options.wind and options.truth is not None:
        raise InputError("--truth", None, "give the wind one way: --wind or --truth, not both")
    if options.still_air and options.given:
        raise InputError("--still-air", None, "--still-air says the wind is zero: not with --wind or --truth")
    if UNKNOWN in options.wind and len(options.wind) > 1:
        raise InputError("--wind", None, "'unknown' is for every log: give --wind once")
    if len(options.wind) > 1 and len(options.wind) != logs:
        raise InputError("--wind", None, f"given {len(options.wind)} times for {logs} logs: once for every log, "
                         "or once per log in the logs' order")
    if options.segment_s is not None and options.wind != (UNKNOWN,):
        raise InputError("--segment-s", None, "only with --wind unknown (one unknown wind per segment)")
    if options.segment_s is not None and not options.segment_s > 0:
        raise InputError("--segment-s", None, f"{options.segment_s:g} must be > 0 s")


def field_truth(options: FieldOptions, af: Airframe, log_paths: list[str]) -> FieldTruth | None:
    """The truth the options name (None: the logs' own wind columns, or --still-air). --wind unknown
    solves for the winds here (CheckFailed when the flight does not identify them)."""
    check_options(options, len(log_paths))
    if options.rate_hz is not None:
        from dobwind.io.autopilot import is_autopilot_log

        if not options.given or not all(is_autopilot_log(p) for p in log_paths):
            raise InputError("--rate", None, "only with --wind or --truth, for autopilot logs (CSV logs keep their "
                             "own clock)")
    if not options.given:
        return None
    summary: list[str] = []
    if options.wind == (UNKNOWN,):
        from dobwind.calibrate.windsolve import GroupWinds, estimate_winds

        solution = estimate_winds(af, [(p, flight_of(p, af, options.rate_hz)) for p in log_paths], options.segment_s)
        truth: Truth = GroupWinds(solution)
        summary = [f"wind (--wind unknown) {g.path} t {g.t_start_s:.1f}-{g.t_end_s:.1f} s: {g.speed_mps:.2f} m/s from "
                   f"{g.from_deg:.0f} deg, 1-sigma {g.sigma_mps:.2f} m/s, {g.direction_text()} ({g.samples} samples)"
                   for g in solution.groups]
        summary.append(f"joint solution: Jacobian condition {solution.condition:.3g}; {'; '.join(solution.notes)}")
    elif len(options.wind) == 1:
        truth = parse_wind(options.wind[0])
    elif options.wind:
        truth = PerLogWind(tuple(zip(log_paths, (parse_wind(text) for text in options.wind))))
    elif options.truth == SITL:
        from dobwind.calibrate.sitlwind import SitlTruth

        truth = SitlTruth()
    else:
        truth = read_truth_csv(str(options.truth))
    # --truth sitl: the logs are ArduPilot SITL's, whose drag acts per body axis (sitlwind.SitlTruth).
    return FieldTruth(truth, truth_reader(truth, options.rate_hz), summary, getattr(truth, "direction_shape", None))


SEGMENT_S = Bound(5.0, 36_000.0, "s")


def add_options(p: argparse.ArgumentParser) -> None:
    """fit's options for autopilot logs and their wind truth."""
    from dobwind.core.options import ULOG_RATE

    p.add_argument("--wind", metavar="SPEED@FROM[,UP]|unknown", action="append", default=[],
                   help="the true wind for logs without wind columns (autopilot logs .ulg/.bin/ROS 2 bags, or CSV): a "
                   "steady wind of SPEED m/s blowing FROM degrees clockwise from north (0 to 360), optional updraft UP "
                   "m/s (e.g. 6.5@270, 6.5@270,0.2, or 6.5@270,-0.2 for a downdraft), for every log, or repeated once per log in the logs' order; or 'unknown': one steady wind per log (or per "
                   "--segment-s) estimated jointly with the force-air law from flight with varied headings and "
                   "speeds, mean vertical wind taken as zero; refused (exit 1) when the flight does not identify it")
    p.add_argument("--truth", metavar="FILE.csv|sitl",
                   help="the true wind as a time series in each log's own time (docs/formats.md, wind truth: t and "
                   "wind_n/wind_e/wind_d, or t, speed, from_deg [, up]); rows outside its span are not used; or "
                   "'sitl': the wind an ArduPilot SITL log's simulator was given (SIM_WIND_* parameters, the "
                   "square-root or linear profile on the barometer altitude); where the flight does not identify "
                   "the drag's direction harmonics, the law then takes the simulator's per-body-axis shape "
                   "(docs/field-calibration.md)")
    p.add_argument("--rate", type=ULOG_RATE,
                   help=f"autopilot logs: resample at this rate, Hz ({ULOG_RATE.text()}) (default: the attitude's clock)")
    p.add_argument("--segment-s", type=SEGMENT_S, metavar="SECONDS",
                   help=f"with --wind unknown: one steady wind per this many seconds of each log ({SEGMENT_S.text()}; "
                   "default: one per log)")


def field_options(args: argparse.Namespace) -> FieldOptions:
    return FieldOptions(tuple(args.wind), args.truth, args.rate, args.segment_s, args.still_air)
