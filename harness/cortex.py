"""Cortex-M4F (single-precision FPU) build of the generated step: no double-precision code, flash size."""
from __future__ import annotations

import re
import shutil
from dataclasses import dataclass
from pathlib import Path

from dobwind.harness.build import STRICT_FLAGS, run
from dobwind.model.layout import Layout

ARM_GCC = "arm-none-eabi-gcc"
CPU_FLAGS = ("-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard")
# The firmware flags the README recommends: without -fno-math-errno, sqrtf stays a library call (errno).
FIRMWARE_FLAGS = ("-Os", "-std=c99", "-fno-math-errno")
# Soft-double helpers (EABI names) and double-precision libm entry points.
_DOUBLE_SYMBOL = re.compile(
    r"^(__aeabi_d\w+|__aeabi_f2d|__aeabi_d2f|__(add|sub|mul|div|extendsf|truncdf)df\w*|"
    r"(sin|cos|tan|asin|acos|atan|atan2|exp|expm1|log|log1p|pow|sqrt|fmod|fabs|floor|ceil|hypot|fmin|fmax|"
    r"sinh|cosh|tanh|erf|copysign))$"
)

FLASH_SECTIONS = {"text", "data", "rodata", "ARM", "init", "fini", "isr_vector"}

_FIRMWARE_MAIN = """\
#include "{name}_wind.h"
volatile {real} sink;
volatile {real} source = ({real})1;
int main(void)
{{
    {prefix}state_t state;
    {prefix}input_t in;
    {prefix}output_t out;
    {init}
    for (;;) {{
{fill}
{call}
        sink = out.wind_speed_h;
    }}
}}
"""


@dataclass(frozen=True)
class CortexBuild:
    double_symbols: tuple[str, ...]  # referenced double-precision routines (must be empty)
    object_text_bytes: int           # the step's own code
    firmware_flash_bytes: int        # text + data of a minimal firmware calling the step
    empty_firmware_flash_bytes: int  # the same firmware without the estimator


def available() -> bool:
    return shutil.which(ARM_GCC) is not None


def flash_size_bytes(path: Path) -> int:
    out = run(["arm-none-eabi-size", "-A", str(path)]).stdout
    total = 0
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].split(".")[1:2] and parts[0].split(".")[1] in FLASH_SECTIONS:
            total += int(parts[1])
    return total


def undefined_symbols(obj: Path) -> list[str]:
    return run(["arm-none-eabi-nm", "-u", str(obj)]).stdout.split()[1::2]


def double_precision_symbols(obj: Path) -> list[str]:
    return sorted(s for s in undefined_symbols(obj) if _DOUBLE_SYMBOL.match(s))


def firmware_main(name: str, input_fields, real: str, with_step: bool) -> str:
    prefix = f"{name}_wind_"
    fill = [f"        in.{name} = source;" for name in Layout(tuple(input_fields)).element_names()]
    return _FIRMWARE_MAIN.format(
        name=name, prefix=prefix, real=real, fill="\n".join(fill),
        init=f"{prefix}init(&state);" if with_step else "(void)state;",
        call=f"        (void){prefix}step(&state, &in, &out);" if with_step else "        out.wind_speed_h = in.dt;",
    )


def build_firmware(sources: list[Path], main_text: str, work: Path, label: str,
                   flags: tuple[str, ...] = ()) -> Path:
    main = work / f"{label}_main.c"
    main.write_text(main_text)
    elf = work / f"{label}.elf"
    run([ARM_GCC, *CPU_FLAGS, *FIRMWARE_FLAGS, "-ffunction-sections", "-fdata-sections", *flags,
         f"-I{work}", str(main), *map(str, sources), "--specs=nosys.specs", "--specs=nano.specs",
         "-Wl,--gc-sections", "-o", str(elf), "-lm"])
    return elf


def check_generated(code_dir: Path, name: str, input_fields, work: Path) -> CortexBuild:
    source = code_dir / f"{name}_wind.c"
    obj = work / f"{name}_wind.o"
    run([ARM_GCC, *CPU_FLAGS, *FIRMWARE_FLAGS, *STRICT_FLAGS, "-ffunction-sections", "-c", str(source), "-o", str(obj)])
    for header in code_dir.glob("*.h"):
        if header.resolve() != (work / header.name).resolve():
            shutil.copy(header, work / header.name)
    with_step = build_firmware([source], firmware_main(name, input_fields, "float", True), work, "with_step")
    empty = build_firmware([], firmware_main(name, input_fields, "float", False), work, "empty")
    return CortexBuild(tuple(double_precision_symbols(obj)), flash_size_bytes(obj), flash_size_bytes(with_step), flash_size_bytes(empty))
