"""Where a command may write, and writing all of a command's outputs together or not at all.

Every writing command (generate, fit, replay, simulate, analyze, demo) checks all its targets with
``check_targets`` before doing any work, then writes through ``OutputFiles`` (files staged under
temporary names and renamed in together at the end) or ``staged_folder`` (a folder built beside the
target and swapped in as a whole). A failure or a signal removes the temporaries and leaves the
earlier outputs exactly as they were.
"""
from __future__ import annotations

import os
import shutil
import stat
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, Sequence

from dobwind.io.logsuffix import LOG_SUFFIXES
from dobwind.io.atomic import TEMP_PREFIX, new_temp_file, public_mode, remove_stale, temp_prefix
from dobwind.core.errors import InputError
from dobwind.core.interrupts import raise_if_caught, signals_deferred


@dataclass(frozen=True)
class Target:
    option: str          # the command-line option that named it ("-o", "--plot")
    path: str
    kind: str = "file"   # "file" or "dir"
    # A file written in one format only (a PNG, an HTML page): the extensions its name may end in (any
    # case), the first naming the format. Empty: any name (CSV, TOML, NetCDF outputs choose by their own rules).
    suffixes: tuple[str, ...] = ()
    # Extensions the name may not end in (any case): a TOML written as x.ulg would pass for a flight log,
    # and the next command given it would read it as one (AIRFRAME below).
    refused: tuple[str, ...] = ()


PNG = (".png",)   # Target.suffixes of a figure (matplotlib is told format="png" whatever the name says)
AIRFRAME = LOG_SUFFIXES  # Target.refused of an airframe file (init, fit): any name but a flight log's
# Target.refused of a CSV output (simulate's log, replay's estimate): `simulate sweep -o fit.toml` replaced a
# fitted airframe with 155 MB of CSV, and the next command given it read a TOML syntax error.
CSV_TABLE = (".toml",)


def shown(path: str | Path) -> str:
    """The path as one printable token (an empty or multi-line name must not break the one-line rule)."""
    text = str(path)
    return text if text and text.isprintable() and text.strip() == text else repr(text)


def _refuse(target: Target, message: str) -> InputError:
    return InputError(f"{target.option} {shown(target.path)}", None, message)


def _stat(path: Path) -> os.stat_result | None:
    try:
        return os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return None


def _nearest_existing(path: Path) -> tuple[Path, os.stat_result]:
    while True:
        found = _stat(path)
        if found is not None or path.parent == path:
            return path, found if found is not None else os.stat(path)
        path = path.parent


def _check_existing(target: Target, st: os.stat_result, inputs: Sequence[str]) -> None:
    if target.kind == "dir":
        if not stat.S_ISDIR(st.st_mode):
            raise _refuse(target, "exists and is not a folder")
        return
    if stat.S_ISDIR(st.st_mode):
        raise _refuse(target, "is a folder; a file is expected")
    if not stat.S_ISREG(st.st_mode):
        raise _refuse(target, "is not a regular file (a device, pipe or socket): refusing to replace it")
    for name in inputs:
        other = _stat(Path(name))
        if other is not None and (other.st_dev, other.st_ino) == (st.st_dev, st.st_ino):
            raise _refuse(target, f"is the input file {shown(name)}: refusing to overwrite it")


def check_target(target: Target, inputs: Sequence[str] = ()) -> None:
    """Raises InputError (naming the option and the path) unless ``target`` can be written."""
    if not target.path:
        raise _refuse(target, "empty path")
    if target.kind == "file" and target.path.endswith(os.sep):  # Path() would drop the slash: "x/" is "x"
        raise _refuse(target, "ends with a slash, which names a folder; a file is expected")
    path = Path(target.path)
    try:
        st = _stat(path)
        if st is not None:
            _check_existing(target, st, inputs)
        folder, st_folder = _nearest_existing(path if st is not None and target.kind == "dir" else path.parent)
    except OSError as exc:
        raise _refuse(target, f"cannot inspect: {exc.strerror}") from None
    if not stat.S_ISDIR(st_folder.st_mode):
        raise _refuse(target, f"{shown(folder)} is a file, not a folder")
    try:  # a real file, not os.access: root passes access() on read-only mounts and on /proc
        with signals_deferred():
            new_temp_file(folder, "probe").unlink()
    except OSError as exc:
        raise _refuse(target, f"cannot write in {shown(folder)}: {exc.strerror}") from None
    _check_suffix(target)


def _check_suffix(target: Target) -> None:
    """A PNG written as r.pdf opens as a broken PDF: a one-format output must be named for its format.
    Checked last, so that a path that cannot be written at all says that first."""
    suffix = Path(target.path).suffix
    if suffix.lower() in target.refused and suffix.lower() in CSV_TABLE:
        raise _refuse(target, f"the extension {suffix!r} names an airframe, but this file is written as CSV: "
                      "name it .csv (an airframe is given with --airframe or as the first argument)")
    if suffix.lower() in target.refused:
        raise _refuse(target, f"the extension {suffix!r} names a flight log, but this file is written as TOML: "
                      "name it .toml")
    if not target.suffixes:
        return
    if suffix.lower() not in target.suffixes:
        got = f"the extension {suffix!r}" if suffix else "no extension"
        kind = target.suffixes[0].lstrip(".").upper()
        raise _refuse(target, f"{got}; it is written as {kind} only: name it {' or '.join(target.suffixes)}")


def check_targets(targets: Sequence[Target], inputs: Sequence[str] = ()) -> None:
    """Every target on its own, and no two targets the same file."""
    seen: dict[str, Target] = {}
    for target in targets:
        check_target(target, inputs)
        key = os.path.abspath(target.path)
        if key in seen:
            raise _refuse(target, f"is also given as {seen[key].option}")
        seen[key] = target


def _write_failed(targets: Sequence[Target], exc: OSError) -> InputError:
    names = ", ".join(f"{t.option} {shown(t.path)}" for t in targets)
    reason = exc.strerror or str(exc)
    return InputError(names, None, f"cannot write: {reason}; nothing was changed")


class OutputFiles:
    """Stages files under temporary names beside their targets; on a clean exit renames them all in
    (restoring the earlier files if a rename fails), on any exception removes them."""

    def __init__(self, targets: Sequence[Target]) -> None:
        self._targets = list(targets)
        self._staged: list[tuple[Path, Path]] = []   # (temporary, final)
        self._made_dirs: list[Path] = []

    def __enter__(self) -> "OutputFiles":
        return self

    def stage(self, final: str | Path) -> Path:
        """A temporary path to write ``final``'s content to; its folder is created if needed."""
        final = Path(final)
        missing = [p for p in (final.parent, *final.parent.parents) if not p.exists()]
        final.parent.mkdir(parents=True, exist_ok=True)
        self._made_dirs.extend(reversed(missing))
        remove_stale(final.parent)
        with signals_deferred():  # created and remembered together, so a signal cannot strand it
            tmp = new_temp_file(final.parent, final.name)
            self._staged.append((tmp, final))
        return tmp

    def __exit__(self, kind, exc, tb) -> None:
        if exc is None:
            try:
                self._commit()
            except OSError as failure:
                self._discard()
                raise _write_failed(self._targets, failure) from None
            except BaseException:
                self._discard()
                raise
            return
        self._discard()
        if isinstance(exc, OSError):
            raise _write_failed(self._targets, exc) from None

    def _discard(self) -> None:
        for tmp, _ in self._staged:
            tmp.unlink(missing_ok=True)
        for folder in reversed(self._made_dirs):
            try:
                folder.rmdir()
            except OSError:
                pass

    def _commit(self) -> None:
        with signals_deferred():
            raise_if_caught()
            backups: list[tuple[Path, Path | None]] = []
            try:
                for tmp, final in self._staged:
                    public_mode(tmp)
                    backup = None
                    if final.exists():
                        backup = new_temp_file(final.parent, final.name)
                        try:
                            os.replace(final, backup)
                        except BaseException:
                            backup.unlink(missing_ok=True)  # not yet a backup: only a stray placeholder
                            raise
                    backups.append((final, backup))
                    os.replace(tmp, final)
            except BaseException:
                for final, backup in reversed(backups):
                    if backup is not None:
                        os.replace(backup, final)
                    else:
                        final.unlink(missing_ok=True)
                raise
            for _, backup in backups:  # inside the deferral: a signal after the renames must not strand these
                if backup is not None:
                    backup.unlink(missing_ok=True)


def check_replaceable(target: Target, owned: Callable[[str], bool]) -> None:
    """A folder that is replaced as a whole may hold only what the command itself writes: `-o .` or
    `-o ~` must never delete anything else."""
    try:
        names = os.listdir(target.path)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise _refuse(target, f"cannot list: {exc.strerror}") from None
    foreign = sorted(n for n in names if not n.startswith(TEMP_PREFIX) and not owned(n))
    if foreign:
        raise _refuse(target, f"holds {shown(foreign[0])}, which this command does not write: refusing to replace "
                              "the folder (choose an empty or new folder)")


def _swap_in(new: Path, final: Path) -> None:
    """Renames the old folder aside, the new one in, then removes the old; restores it on failure."""
    with signals_deferred():
        raise_if_caught()
        old = None
        if final.exists():
            old = Path(tempfile.mkdtemp(prefix=temp_prefix(), suffix=f"-old-{final.name}", dir=final.parent))
            try:
                os.replace(final, old)  # onto the empty placeholder folder
            except BaseException:
                os.rmdir(old)  # no stray placeholder beside the untouched target
                raise
        try:
            os.rename(new, final)
        except BaseException:
            if old is not None:
                os.rename(old, final)
            raise
        if old is not None:  # inside the deferral: a signal after the renames must not strand it
            shutil.rmtree(old, ignore_errors=True)


@contextmanager
def staged_folder(target: Target) -> Iterator[Path]:
    """Yields an empty sibling folder to fill; on a clean exit it replaces ``target`` as a whole. A target
    that is a symbolic link to a folder replaces the folder it points to (the link stays as it is)."""
    final = Path(target.path)
    if final.is_symlink() and final.is_dir():
        final = final.resolve()
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        remove_stale(final.parent)
    except OSError as exc:
        raise _write_failed([target], exc) from None
    new = None
    try:
        with signals_deferred():
            new = Path(tempfile.mkdtemp(prefix=temp_prefix(), suffix=f"-{final.name}", dir=final.parent))
        yield new
        public_mode(new, directory=True)
        _swap_in(new, final)
    except OSError as exc:
        if new is not None:
            shutil.rmtree(new, ignore_errors=True)
        raise _write_failed([target], exc) from None
    except BaseException:
        if new is not None:
            shutil.rmtree(new, ignore_errors=True)
        raise
