"""The folder compiled host libraries are cached in, publishing a library into it, and the small
host libraries rendered from a template (the CSV formatter and parser) built into it once."""
from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import tempfile
from pathlib import Path


def cache_dir() -> Path:
    """$DOBWIND_CACHE, else $XDG_CACHE_HOME/dobwind, else ~/.cache/dobwind."""
    if os.environ.get("DOBWIND_CACHE"):
        return Path(os.environ["DOBWIND_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "dobwind"


def publish(built: Path, target: Path) -> bool:
    """Puts a library into the cache under ``target`` (a hard link, else a copy renamed into place, so
    that no reader sees a partial file); False when the folder is not usable."""
    staged = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        handle, name = tempfile.mkstemp(prefix=f".{target.name}.", dir=target.parent)
        os.close(handle)
        staged = Path(name)
        try:
            staged.unlink()
            os.link(built, staged)
        except OSError:
            shutil.copyfile(built, staged)
        os.replace(staged, target)
        # rename() does nothing when both names are links to one file (a concurrent publisher got there
        # first with the same library): the staged name is then still there.
        staged.unlink(missing_ok=True)
        return True
    except OSError:
        if staged is not None:
            staged.unlink(missing_ok=True)
        return False


def _compile_command() -> list[str]:
    from dobwind.harness.build import C_STD, STRICT_FLAGS, system_compiler

    return [system_compiler(), C_STD, *STRICT_FLAGS, "-O2", "-fPIC", "-shared"]


def _template_key(template: str, params: dict, command: list[str]) -> str:
    """What such a library is made from: the template's text, its parameters, the compiler and flags."""
    from dobwind.harness import build

    digest = hashlib.sha256((Path(build.__file__).parent / "templates" / template).read_bytes() + b"\0")
    digest.update(repr(sorted(params.items())).encode() + b"\0" + "\0".join(command).encode())
    return digest.hexdigest()[:32]


def load_template_library(template: str, params: dict) -> ctypes.CDLL | None:
    """harness/templates/<template> rendered with ``params``, compiled to a shared library and loaded:
    from the cache, built and added on a miss; None when no compiler can build it. Keyed on what it is
    made from, so a hit neither renders nor compiles. With an unusable cache folder the private build
    is loaded before its folder goes (the loader keeps its mapping)."""
    command = _compile_command()
    target = cache_dir() / f"lib{template.split('.')[0]}_{_template_key(template, params, command)}.so"
    if target.is_file():
        return ctypes.CDLL(str(target))
    if shutil.which(command[0]) is None:
        return None
    from dobwind.harness.build import HARNESS_TEMPLATES, run
    from dobwind.model.errors import CheckFailed

    with tempfile.TemporaryDirectory(prefix="dobwind-") as tmp:
        source = Path(tmp) / template.removesuffix(".j2")
        source.write_text(HARNESS_TEMPLATES.get_template(template).render(**params))
        built = Path(tmp) / target.name
        try:
            run([*command, str(source), "-o", str(built), "-lm"])
        except (CheckFailed, OSError):
            return None
        return ctypes.CDLL(str(target if publish(built, target) else built))
