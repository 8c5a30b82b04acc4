"""Compiling generated C: strict flags, several compilers, shared libraries for ctypes."""
from __future__ import annotations

import os
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import jinja2

from dobwind.model.errors import CheckFailed
from dobwind.model.layout import Layout
from dobwind.model.step import StepModel
from dobwind.model.kinds import Precision

STRICT_FLAGS = ("-Wall", "-Wextra", "-Wpedantic", "-Wconversion", "-Wdouble-promotion", "-Werror")
C_STD = "-std=c99"
CXX_STD = "-std=c++11"

HARNESS_TEMPLATES = jinja2.Environment(
    loader=jinja2.PackageLoader("dobwind.harness", "templates"),
    undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True,
)


@dataclass(frozen=True)
class Compiler:
    label: str
    command: str
    language: str  # "c" | "c++"

    def flags(self) -> list[str]:
        std = C_STD if self.language == "c" else CXX_STD
        lang = ["-x", "c++"] if self.language == "c++" else []
        return [*lang, std, *STRICT_FLAGS]


def system_compiler() -> str:
    return os.environ.get("CC", "cc")


def available_compilers() -> list[Compiler]:
    """$CC (default cc) as C, the C++ compiler on the C file, and clang when it is installed."""
    found = [Compiler("cc (C99)", system_compiler(), "c")]
    cxx = os.environ.get("CXX", "c++")
    if shutil.which(cxx):
        found.append(Compiler("c++ (C++11)", cxx, "c++"))
    if shutil.which("clang") and Path(shutil.which("clang")).resolve() != Path(shutil.which(system_compiler()) or "").resolve():
        found.append(Compiler("clang (C99)", "clang", "c"))
    return found


def run(cmd: list[str], cwd: Path | None = None) -> subprocess.CompletedProcess:
    try:
        done = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, errors="replace")
    except OSError as exc:  # a compiler that exited 0 without writing its program, a missing tool
        raise CheckFailed(f"{cmd[0]}: cannot run: {exc.strerror or exc}") from None
    if done.returncode != 0:
        raise CheckFailed(f"{' '.join(cmd)} failed:\n{done.stdout}{done.stderr}".rstrip())
    return done


def strict_compile(compiler: Compiler, source: Path, out_dir: Path) -> None:
    run([compiler.command, *compiler.flags(), "-O2", "-c", str(source), "-o", str(out_dir / f"{source.stem}.{compiler.language.replace('+', 'x')}.o")])


def _element_paths(layout: Layout, prefix: str) -> list[str]:
    return [prefix + name for name in layout.element_names()]


def write_shim(model: StepModel, precision: Precision, out_dir: Path) -> Path:
    real = "float" if precision == Precision.SINGLE else "double"
    name = model.airframe.name
    state = _element_paths(model.state, "s->")
    inputs = _element_paths(model.inputs, "in->")
    outputs = _element_paths(model.outputs, "out->")
    text = HARNESS_TEMPLATES.get_template("shim.c.j2").render(
        name=name, prefix=f"{name}_wind_", n_in=model.inputs.size, n_state=model.state.size, n_out=model.outputs.size,
        load_state=[f"{p} = ({real})x[{i}];" for i, p in enumerate(state)],
        save_state=[f"x[{i}] = (double){p};" for i, p in enumerate(state)],
        load_input=[f"{p} = ({real})u[{i}];" for i, p in enumerate(inputs)],
        save_output=[f"y[{i}] = (double){p};" for i, p in enumerate(outputs)],
        real=real,
        load_state_native=[f"{p} = x[{i}];" for i, p in enumerate(state)],
        save_state_native=[f"x[{i}] = {p};" for i, p in enumerate(state)],
        load_input_native=[f"{p} = u[{i}];" for i, p in enumerate(inputs)],
        save_output_native=[f"y[{i}] = {p};" for i, p in enumerate(outputs)],
    )
    path = out_dir / "dobwind_shim.c"
    path.write_text(text)
    return path


def build_shared_library(model: StepModel, precision: Precision, code_dir: Path, out_dir: Path,
                         extra_flags: tuple[str, ...] = ()) -> Path:
    shim = write_shim(model, precision, out_dir)
    library = out_dir / f"lib{model.airframe.name}_{precision}.so"
    run([system_compiler(), C_STD, *STRICT_FLAGS, "-O2", "-fPIC", "-shared", *extra_flags, f"-I{code_dir}",
         str(code_dir / f"{model.airframe.name}_wind.c"), str(shim), "-o", str(library), "-lm"])
    if not library.is_file():
        raise CheckFailed(f"{system_compiler()} exited 0 but wrote no {library.name}")
    return library
