"""A normal (non-editable) install works: the wheel carries the airframes and templates, and the
commands run from a folder that is not the checkout (issue #15: `pip install .` used to exit 2)."""
from __future__ import annotations

import os
import shutil
import subprocess
import re
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

from tests.helpers import ROOT

SOURCES = ("pyproject.toml", "README.md", "dobwind", "model", "codegen", "harness", "airframes")


def _run(cmd: list[str], cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    done = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env)
    assert done.returncode == 0, f"{' '.join(cmd)}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
    return done


def _wheel(tmp: Path) -> Path:
    """Builds from a copy of the sources so the checkout gets no build/ or egg-info folders. With pip's
    build isolation, as `make setup` does: setuptools comes from pip's cache or the package index."""
    src = tmp / "src"
    src.mkdir()
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy2(ROOT / name, src / name)
    _run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(tmp / "dist"),
          str(src)], tmp, timeout=180)
    (wheel,) = (tmp / "dist").glob("dobwind-*.whl")
    return wheel


def _fresh_venv(tmp: Path, wheel: Path) -> Path:
    """A new venv outside the checkout; its dependencies come from the project's venv through a .pth
    line (appended after the venv's own site-packages, so the installed wheel is what gets imported)."""
    venv = tmp / "fresh"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], tmp)
    python = venv / "bin" / "python"
    purelib = _run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], tmp).stdout.strip()
    Path(purelib, "zz_project_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "--quiet", "--no-deps", "--no-index",
          str(wheel)], tmp)
    return venv


def test_wheel_installs_and_runs_outside_the_checkout(tmp_path):
    wheel = _wheel(tmp_path)
    names = set(zipfile.ZipFile(wheel).namelist())
    for data in ("dobwind/airframes/m300.toml", "dobwind/airframes/nf_quad.toml", "dobwind/report/report.html.j2",
                 "dobwind/io/msgs/px4_msgs/EscReport.msg", "dobwind/io/msgs/mavros_msgs/ESCStatus.msg"):  # ROS 2 bags
        assert data in names, f"the wheel lacks {data}"
    # benchmarks and development tools stay in the checkout (issue #34): none of them ships
    shipped_dev = sorted(n for n in names if n.split("/")[0] in ("benchmarks", "tools")
                         or re.search(r"/(accuracy\w*|realdata|tunnelruns|regen|docfigures|bench\w*|mutant\w*)\.py$", n))
    assert shipped_dev == []
    venv = _fresh_venv(tmp_path, wheel)
    work = tmp_path / "elsewhere"
    work.mkdir()
    dobwind = str(venv / "bin" / "dobwind")
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert _run([dobwind, "--version"], work).stdout.strip() == f"dobwind {version}"
    where = _run([str(venv / "bin" / "python"), "-c", "import dobwind.core.resources as r; print(r.shipped_airframe())"], work)
    assert str(venv) in where.stdout and str(ROOT) not in where.stdout  # the wheel's copy, not the checkout's
    _run([dobwind, "simulate", "tunnel", "--hold", "2", "--rate", "25", "-o", "t.csv"], work)
    assert (work / "t.csv").stat().st_size > 0
    airframe = work / "m300.toml"
    airframe.write_text(Path(where.stdout.strip()).read_text())
    _run([dobwind, "generate", "m300.toml", "-o", "c"], work)
    assert (work / "c" / "m300_wind.c").is_file()
    _run([dobwind, "verify", "m300.toml", "--precision", "single", "--steps", "200"], work, timeout=300)
    _run([dobwind, "replay", "m300.toml", "t.csv", "--json"], work)
