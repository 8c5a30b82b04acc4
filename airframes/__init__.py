"""The shipped airframes (TOML package data, read through dobwind.core.resources). This file only makes the folder
an importable package, which editable installs need to map it to dobwind.airframes."""
