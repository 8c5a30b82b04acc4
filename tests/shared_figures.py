"""The analysis figures of `dobwind report`, computed once per airframe in a test process (issue #34).

Every report page carries the airframe's analysis (dobwind/analysis/report.py ``analyze``: the observer and
low-pass responses, 1.4-2.5 s) and its three figures (``write_plots``: 1-2 s of matplotlib), half or more of a
report's time, and the same for every report on one airframe. Both are pure functions of the airframe and the
frequencies asked, so a test that asks for ``shared_figures`` gets them computed once per distinct call in its
process (a pytest-xdist worker), across modules; the replay, its figure and the page are built whole each time.
``analyze`` is keyed by its arguments' content (pickled, hashed: any change in the airframe is a new call);
``write_plots`` is shared only when it is handed a result of the memo's ``analyze`` unchanged (the systems
object itself, and a report equal to the one computed): the PNG bytes written the first time are written again.
"""
from __future__ import annotations

import copy
import hashlib
import pickle
from pathlib import Path
from typing import Any, Callable

import pytest


class FigureMemo:
    """``analyze`` and ``write_plots`` computed once per airframe and frequencies; ``calls`` and ``computed``
    count analyze's calls and real computations, ``drawn`` the real write_plots calls."""

    def __init__(self, analyze: Callable, write_plots: Callable):
        self._analyze, self._write_plots = analyze, write_plots
        self.results: dict[str, tuple[dict[str, Any], Any]] = {}
        self.pngs: dict[str, list[tuple[str, bytes]]] = {}
        self.calls = self.computed = self.drawn = 0

    def analyze(self, *args, **kwargs):
        self.calls += 1
        key = hashlib.sha256(pickle.dumps((args, sorted(kwargs.items())))).hexdigest()
        if key not in self.results:
            self.computed += 1
            self.results[key] = self._analyze(*args, **kwargs)
        report, systems = self.results[key]
        # the caller may change the report it is given; the systems are only read (plotted), and their
        # identity is what lets write_plots find the figures already drawn for them
        return copy.deepcopy(report), systems

    def _key_of(self, report: dict[str, Any], systems: Any) -> str | None:
        return next((key for key, (mine, kept) in self.results.items() if kept is systems and mine == report), None)

    def write_plots(self, report: dict[str, Any], systems: Any, out_dir: Path, stage: Callable | None = None) -> list[Path]:
        key = self._key_of(report, systems) if stage is None else None
        if key is not None and key in self.pngs:
            out_dir.mkdir(parents=True, exist_ok=True)
            for name, data in self.pngs[key]:
                (out_dir / name).write_bytes(data)
            return [out_dir / name for name, _ in self.pngs[key]]
        self.drawn += 1
        written = self._write_plots(report, systems, out_dir, stage)
        if key is not None:
            self.pngs[key] = [(path.name, path.read_bytes()) for path in written]
        return written


_MEMO: list[FigureMemo] = []  # one per process: a session fixture would be one per module importing it


def use_shared_figures(patch: pytest.MonkeyPatch) -> FigureMemo:
    """The process's memo in place of analyze and write_plots until ``patch`` is undone."""
    from dobwind.analysis import report

    if not _MEMO:
        _MEMO.append(FigureMemo(report.analyze, report.write_plots))
    patch.setattr(report, "analyze", _MEMO[0].analyze)
    patch.setattr(report, "write_plots", _MEMO[0].write_plots)
    return _MEMO[0]


@pytest.fixture
def shared_figures(monkeypatch: pytest.MonkeyPatch) -> FigureMemo:
    """The memo for the requesting test only (a module-scoped fixture calls use_shared_figures with its own
    MonkeyPatch context)."""
    return use_shared_figures(monkeypatch)
