"""The Python reference's rolled step run as CasADi's own generated C, compiled once into the library cache.

The reference is a CasADi Function; CasADi's virtual machine evaluates its instructions one at a time
(0.7 s of an hour's replay at 100 Hz, issue #13). ``CodeGenerator`` prints the same instructions as C
(a line per instruction, libm for the transcendental ones, as the VM calls), so compiled without
floating-point contraction or fast-math the numbers are the VM's bit for bit
(``tests/test_casadi_lib.py`` holds them equal over whole trajectories). This is CasADi's printer, not
dobwind's: the comparison of dobwind's generated C with the reference stays a comparison of two
printers. Without a compiler the VM is used.
"""
from __future__ import annotations

import functools
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

from dobwind.harness.build import run, system_compiler
from dobwind.harness.libcache import cache_dir, publish
from dobwind.model.errors import CheckFailed

# -std=c99: CasADi's helpers fall back to other formulas before C99 (fmin/fmax as comparisons, which treat
# NaN otherwise; expm1 as exp - 1), and some compilers default to gnu89. -ffp-contract=off: a fused
# multiply-add rounds once where the VM rounds twice (gcc contracts by default on targets with FMA).
# -fno-fast-math for compilers whose default is not IEEE.
FLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-ffp-contract=off", "-fno-fast-math")


def generated_source(function: ca.Function) -> str:
    """CasADi's C for ``function`` (deterministic: the same Function prints the same text)."""
    generator = ca.CodeGenerator(f"{function.name()}_casadi", {"with_header": False})
    generator.add(function)
    return generator.dump()


@functools.lru_cache(maxsize=None)
def compiler_identity(compiler: str) -> str:
    """What the compiler named ``compiler`` is: its resolved path, version and target ("" when it cannot
    say), so that a swapped or upgraded compiler behind the same name misses the cache."""
    path = shutil.which(compiler)
    if path is None:
        return ""
    try:
        # -v: version and target on stderr (gcc and clang alike)
        done = subprocess.run([path, "-v"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return os.path.realpath(path)
    return os.path.realpath(path) + "\0" + done.stdout + done.stderr


def _key(source: str, command: list[str]) -> str:
    digest = hashlib.sha256(source.encode() + b"\0" + "\0".join(command).encode() + b"\0")
    digest.update(compiler_identity(command[0]).encode() + b"\0" + ca.__version__.encode())
    return digest.hexdigest()[:32]


def library_path(function: ca.Function, source: str, command: list[str]) -> Path:
    """Where the cache keeps ``function``'s library: named by its source and the build command."""
    return cache_dir() / f"libcasadi_{function.name()}_{_key(source, command)}.so"


def compiled_function(function: ca.Function) -> ca.Function | None:
    """``function`` as an external Function loaded from its compiled CasADi C (from the cache, built on a
    miss), or None when it cannot be had: no compiler, a failed build, no room for the build (a full
    disk), a library that does not load. It is only ever a faster way to the same numbers, so any of
    these falls back to the VM. The library's name is its source's key: two Functions never share one."""
    command = [system_compiler(), *FLAGS]
    source = generated_source(function)
    target = library_path(function, source, command)
    try:
        if target.is_file():
            try:
                return ca.external(function.name(), str(target))
            except RuntimeError:  # not a loadable library (a damaged cache): built again below
                target.unlink(missing_ok=True)
        if shutil.which(command[0]) is None:
            return None
        with tempfile.TemporaryDirectory(prefix="dobwind-") as tmp:
            path = Path(tmp) / "function.c"
            path.write_text(source)
            built = Path(tmp) / target.name
            run([*command, str(path), "-o", str(built), "-lm"])
            if publish(built, target):
                return ca.external(function.name(), str(target))
            return ca.external(function.name(), str(built))  # loaded before the folder goes
    except (OSError, CheckFailed, RuntimeError):  # RuntimeError: CasADi could not load the library
        return None
