"""Files shipped inside the package (the airframes), found through importlib.resources.

The checkout keeps them in the top-level ``airframes/`` folder (hooks and docs name that path);
pyproject.toml maps that folder to the ``dobwind.airframes`` package so a wheel carries them too.
Looking them up relative to ``__file__`` broke every non-editable install, hence this module."""
from __future__ import annotations

from importlib import resources
from pathlib import Path

REFERENCE_NAME = "m300"  # the paper's vehicle: the default of `simulate` and the subject of `demo`


def shipped_airframe_names() -> list[str]:
    """The stems of the airframes the package carries, sorted."""
    return sorted(entry.name.removesuffix(".toml") for entry in resources.files("dobwind.airframes").iterdir()
                  if entry.name.endswith(".toml"))


def shipped_airframe(name: str = REFERENCE_NAME) -> Path:
    """The path of a shipped airframe. Installs from a wheel or a checkout keep package data as plain
    files, so the resource is a real path (load_airframe and its error messages need one)."""
    entry = resources.files("dobwind.airframes") / f"{name}.toml"
    path = Path(str(entry))
    if not path.is_file():
        raise FileNotFoundError(f"no shipped airframe '{name}' (have: {', '.join(shipped_airframe_names())})")
    return path
