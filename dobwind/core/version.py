"""The installed package's version, for --version and the report's footer."""
from __future__ import annotations


def package_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("dobwind")
    except PackageNotFoundError:  # run from a checkout that was never installed
        from dobwind import __version__

        return __version__
