"""Many flights at once (`replay` and `profile` with several logs or a folder): worker processes,
a progress bar over logs, one summary table.

A worker runs exactly what a single-log command runs, so every output equals the single run's: for
`replay` it is the command itself (``dobwind.cli.app.main`` with the log's own -o and --json), its stdout
and stderr captured and handed back.
"""
from __future__ import annotations

import contextlib
import io
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from dobwind.core.errors import InputError
from dobwind.core.options import Bound
from dobwind.io.logsuffix import LOG_SUFFIXES

JOBS = Bound(1, 256, "processes", integer=True)


def default_jobs() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not Linux
        return max(1, os.cpu_count() or 1)


def _is_bag_folder(path: Path) -> bool:
    return (path / "metadata.yaml").is_file()


def is_log_folder(path: str) -> bool:
    """A folder of logs (not a ROS 2 bag folder, which is one log)."""
    p = Path(path)
    return p.is_dir() and not _is_bag_folder(p)


def expand_logs(items: Sequence[str]) -> list[str]:
    """Files as given; a folder of logs -> its logs (by suffix, any case) and bag folders, sorted by name."""
    logs: list[str] = []
    for item in items:
        if not is_log_folder(item):
            logs.append(item)
            continue
        try:
            entries = sorted(Path(item).iterdir())
        except OSError as exc:
            raise InputError(item, None, f"cannot list: {exc.strerror}") from None
        found = [str(e) for e in entries if (e.is_file() and e.suffix.lower() in LOG_SUFFIXES)
                 or (e.is_dir() and _is_bag_folder(e))]
        if not found:
            raise InputError(item, None, f"holds no flight logs ({', '.join(LOG_SUFFIXES)} files or ROS 2 bag folders)")
        logs.extend(found)
    return logs


def is_many(items: Sequence[str]) -> bool:
    return len(items) > 1 or (len(items) == 1 and is_log_folder(items[0]))


@dataclass(frozen=True)
class Done:
    log: str
    value: Any = None        # the job's result
    error: str | None = None  # one line, when the job failed
    code: int = 0


def _progress(total: int, label: str, enabled: bool):
    if not enabled:
        return contextlib.nullcontext(None)
    from tqdm import tqdm

    return tqdm(total=total, desc=label, unit="log", leave=False, file=sys.stderr)


def run_all(job: Callable[..., Done], args_per_log: list[tuple], logs: list[str], jobs: int, label: str,
            show_progress: bool) -> list[Done]:
    """job(*args) for every log, in worker processes (``jobs`` of them; 1: in this process), results in
    the logs' order. The bar counts logs as they finish."""
    from concurrent.futures import ProcessPoolExecutor, as_completed  # here: multiprocessing costs every command's start

    results: dict[int, Done] = {}
    with _progress(len(logs), label, show_progress) as bar:
        if jobs <= 1 or len(logs) == 1:
            for k, args in enumerate(args_per_log):
                results[k] = _stop_if_interrupted(job(*args))
                if bar is not None:
                    bar.update(1)
        else:
            pool = ProcessPoolExecutor(max_workers=min(jobs, len(logs)), initializer=_worker_init)
            try:
                futures = {pool.submit(job, *args): k for k, args in enumerate(args_per_log)}
                for future in as_completed(futures):
                    results[futures[future]] = _stop_if_interrupted(future.result())
                    if bar is not None:
                        bar.update(1)
            except BaseException:
                pool.shutdown(wait=True, cancel_futures=True)  # no log starts after a stop or a failure
                raise
            pool.shutdown(wait=True)
    return [results[k] for k in range(len(logs))]


def _worker_init() -> None:
    """Workers ignore SIGINT/SIGTERM between jobs (the parent decides to stop); a job's own command
    installs dobwind's handlers while it runs, so the log in progress still cleans up after itself."""
    import signal

    from dobwind.core.interrupts import HANDLED

    for signo in HANDLED:
        signal.signal(signo, signal.SIG_IGN)


def _stop_if_interrupted(done: Done) -> Done:
    """A job that a signal ended (exit 128 + n) stops the whole run, as it would stop one command."""
    if done.code > 128:
        from dobwind.core.interrupts import Interrupted

        # The job's own handler took the signal; sent again, it reaches this command's handler, which
        # records it (the command line then says "stopped by ...") and raises.
        os.kill(os.getpid(), done.code - 128)
        raise Interrupted(done.code - 128)
    return done


def run_command(main: Callable[[list[str]], int], log: str, argv: list[str]) -> Done:
    """One single-log command, captured: (exit status, its stdout, its stderr lines). ``main`` is the
    command line's entry point, handed in by the caller so that this module does not import it back."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except Exception as exc:  # noqa: BLE001 - a bug in one log's run must not lose the others'
            code, err = 1, io.StringIO(f"dobwind: internal error on {log}: {type(exc).__name__}: {exc}\n")
    return Done(log, (out.getvalue(), err.getvalue()), None if code == 0 else _last_line(err.getvalue()), code)


def _last_line(text: str) -> str:
    lines = [line for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else "failed"


def output_names(logs: list[str], folder: str, suffix: str) -> list[str]:
    """One output per log in ``folder``: the log's name with ``suffix`` instead of its own. Two logs
    of the same name (from different folders) would overwrite each other: refused, naming both."""
    seen: dict[str, str] = {}
    out = []
    for log in logs:
        name = Path(log).name
        stem = name[: -len(Path(name).suffix)] if Path(name).suffix else name
        target = os.path.join(folder, stem + suffix)
        if target in seen:
            raise InputError(log, None, f"would write {target}, as {seen[target]} does: rename one of the logs")
        seen[target] = log
        out.append(target)
    return out


def format_table(header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(h), *(len(r[k]) for r in rows)) if rows else len(h) for k, h in enumerate(header)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(header, widths))]
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in rows]
    return "\n".join(lines)
