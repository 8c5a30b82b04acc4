"""The file name endings of the flight logs dobwind reads, in a module of their own: the output checks
(dobwind/io/outputs.py) refuse them as an airframe's name without importing the readers."""
from __future__ import annotations

ULOG_SUFFIXES = (".ulg",)
DATAFLASH_SUFFIXES = (".bin",)
ROSBAG_SUFFIXES = (".mcap", ".db3")
AUTOPILOT_SUFFIXES = ULOG_SUFFIXES + DATAFLASH_SUFFIXES + ROSBAG_SUFFIXES
# Every flight log by name (docs/formats.md: a CSV flight log too); a folder is a ROS 2 bag.
LOG_SUFFIXES = AUTOPILOT_SUFFIXES + (".csv",)
