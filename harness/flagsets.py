"""The autopilots' own compile flags, and builds of the generated C with them.

PX4 builds every C file with the set of cmake/px4_add_common_flags.cmake (issue #32 lists it);
ArduPilot builds C and C++ on ChibiOS boards with Tools/ardupilotwaf/boards.py's sets (the Board base
class, the chibios class and the --Werror extras). The sets below are those flags as the autopilots pass
them to the compiler for a Cortex-M4F board, minus what only links (--specs) or names their own trees
(-I, -D of their configuration). Each compiler gets the set once: host gcc and clang (clang does not know
a few gcc options, which it would otherwise turn into errors under -Werror) and arm-none-eabi-gcc with the
Cortex-M4F CPU flags.
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from dobwind.harness.build import run
from dobwind.harness.cortex import CPU_FLAGS

PX4_C = (
    "-std=gnu11", "-O2", "-fdata-sections", "-ffunction-sections", "-fomit-frame-pointer",
    "-funsafe-math-optimizations", "-fno-strict-aliasing", "-fno-math-errno", "-Wall", "-Wextra", "-Werror",
    "-Warray-bounds", "-Wcast-align", "-Wdisabled-optimization", "-Wdouble-promotion", "-Wfatal-errors",
    "-Wfloat-equal", "-Wformat-security", "-Winit-self", "-Wlogical-op", "-Wpointer-arith", "-Wshadow",
    "-Wuninitialized", "-Wunknown-pragmas", "-Wunused-variable", "-Wno-missing-field-initializers",
    "-Wno-unused-parameter", "-fno-common", "-Wbad-function-cast", "-Wnested-externs", "-Wstrict-prototypes",
    "-fno-builtin-printf", "-fno-strength-reduce", "-Wformat=1", "-Wunused-but-set-variable",
)
# PX4 compiles C++ (a module) with the same warnings, C++14 and without exceptions or RTTI.
PX4_CXX = (
    "-std=gnu++14", "-O2", "-fdata-sections", "-ffunction-sections", "-fomit-frame-pointer",
    "-funsafe-math-optimizations", "-fno-strict-aliasing", "-fno-math-errno", "-fno-exceptions", "-fno-rtti",
    "-fno-threadsafe-statics", "-Wall", "-Wextra", "-Werror", "-Warray-bounds", "-Wcast-align",
    "-Wdisabled-optimization", "-Wdouble-promotion", "-Wfatal-errors", "-Wfloat-equal", "-Wformat-security",
    "-Winit-self", "-Wlogical-op", "-Wpointer-arith", "-Wshadow", "-Wuninitialized", "-Wunknown-pragmas",
    "-Wunused-variable", "-Wno-missing-field-initializers", "-Wno-unused-parameter", "-fno-common",
    "-Wreorder", "-Wno-overloaded-virtual", "-fcheck-new", "-fno-builtin-printf", "-Wformat=1",
    "-Wunused-but-set-variable",
)
# The Board class's CFLAGS, the chibios class's, and the --Werror extras.
_ARDUPILOT_COMMON = (
    "-ffunction-sections", "-fdata-sections", "-fsigned-char", "-Wall", "-Wextra", "-Werror=format",
    "-Wpointer-arith", "-Wcast-align", "-Wno-missing-field-initializers", "-Wno-unused-parameter",
    "-Wno-redundant-decls", "-Wno-unknown-pragmas", "-Wno-trigraphs", "-Werror=shadow", "-Werror=return-type",
    "-Werror=unused-result", "-Werror=unused-variable", "-Werror=attributes", "-Werror=overflow",
    "-Werror=parentheses", "-Werror=format-extra-args", "-Werror=ignored-qualifiers", "-Werror=undef",
    "-DARDUPILOT_BUILD", "-fsingle-precision-constant", "-Wdouble-promotion",
    "-Wlogical-op", "-Wframe-larger-than=1300", "-Wno-sign-compare", "-Wfloat-equal",
    "-Wmissing-declarations", "-Werror=array-bounds", "-Wfatal-errors", "-Werror=uninitialized",
    "-Werror=init-self", "-Werror=unused-but-set-variable", "-fno-strict-aliasing", "-fomit-frame-pointer",
    "-falign-functions=16", "-fno-strength-reduce", "-fno-builtin-printf", "-Werror=deprecated-declarations",
    "-DNDEBUG=1", "-Os", "-Werror", "-Werror=missing-declarations", "-Werror=float-equal",
)
ARDUPILOT_C = ("-std=c11", *_ARDUPILOT_COMMON)
ARDUPILOT_CXX = (
    "-std=gnu++11", *_ARDUPILOT_COMMON, "-fno-exceptions", "-fno-rtti", "-fno-threadsafe-statics",
    "-Werror=reorder", "-Werror=cast-align", "-Werror=format-security", "-Werror=enum-compare",
    "-Werror=narrowing", "-Werror=switch", "-Werror=sign-compare", "-Werror=type-limits", "-Werror=unused-value",
    "-Werror=delete-non-virtual-dtor", "-Werror=double-promotion", "-Werror=suggest-override",
    "-Werror=implicit-fallthrough", "-Werror=maybe-uninitialized", "-Werror=duplicated-cond",
)

# What clang needs to take a gcc flag set: its name for single-precision constants, and no error for the
# options it does not have (it ignores them, which is what they would do for it anyway).
_CLANG_RENAMES = {"-fsingle-precision-constant": "-cl-single-precision-constant"}
_CLANG_EXTRA = ("-Wno-unknown-warning-option", "-Wno-ignored-optimization-argument", "-Wno-gnu-designator")
_CLANG_DROPS = {"-fno-strength-reduce", "-falign-functions=16", "-fcheck-new"}


@dataclass(frozen=True)
class FlagSet:
    name: str            # "px4" | "ardupilot"
    c: tuple[str, ...]
    cxx: tuple[str, ...]
    # False where -fsingle-precision-constant turns every unsuffixed (double) literal into a float: the
    # double-precision C would silently lose its precision, so only single precision is built with it.
    double_ok: bool = True


FLAG_SETS = {
    "px4": FlagSet("px4", PX4_C, PX4_CXX),
    "ardupilot": FlagSet("ardupilot", ARDUPILOT_C, ARDUPILOT_CXX, double_ok=False),
}


@dataclass(frozen=True)
class Toolchain:
    label: str
    cc: str
    cxx: str
    extra: tuple[str, ...] = ()  # CPU flags
    hosted: bool = True          # can run what it builds here
    clang: bool = False

    def adapt(self, flags: tuple[str, ...]) -> list[str]:
        if not self.clang:
            return [*flags, *self.extra]
        kept = [_CLANG_RENAMES.get(f, f) for f in flags if f not in _CLANG_DROPS]
        return [*kept, *_CLANG_EXTRA, *self.extra]


TOOLCHAINS = (
    Toolchain("gcc", "gcc", "g++"),
    Toolchain("clang", "clang", "clang++", clang=True),
    Toolchain("arm-none-eabi-gcc (Cortex-M4F)", "arm-none-eabi-gcc", "arm-none-eabi-g++", CPU_FLAGS, hosted=False),
)


def available_toolchains() -> list[Toolchain]:
    return [t for t in TOOLCHAINS if shutil.which(t.cc)]


def compile_c(toolchain: Toolchain, flags: FlagSet, sources: list[Path], out_dir: Path, cxx: bool = False) -> None:
    """Compiles each source on its own (-c) with the set; C++ compiles the C file as C++ (-x c++), as a
    translation unit of an ArduPilot library would include it."""
    command = toolchain.cxx if cxx else toolchain.cc
    language = ["-x", "c++"] if cxx else []
    for source in sources:
        run([command, *language, *toolchain.adapt(flags.cxx if cxx else flags.c), f"-I{source.parent}", "-c",
             str(source), "-o", str(out_dir / f"{source.stem}.{toolchain.cc}.{'cxx' if cxx else 'c'}.o")])


def build_selftest(toolchain: Toolchain, flags: FlagSet, code_dir: Path, name: str, out_dir: Path) -> Path:
    """The generated self-test linked with the set (host toolchains only)."""
    exe = out_dir / f"selftest-{flags.name}-{toolchain.cc}"
    run([toolchain.cc, *toolchain.adapt(flags.c), str(code_dir / f"{name}_wind.c"),
         str(code_dir / f"{name}_wind_selftest.c"), "-o", str(exe), "-lm"])
    return exe
