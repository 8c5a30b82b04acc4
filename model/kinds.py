"""The named kinds the airframe, the generated C and the command line share, as enums whose members
are their strings (``Precision.SINGLE == "single"``): the TOML, the JSON and the command line keep
the same words, and a typo in the code is an AttributeError instead of a comparison that is never true."""
from __future__ import annotations

from enum import StrEnum


class Precision(StrEnum):
    """The floating-point type of the generated C (and of the compiled replay backend)."""
    SINGLE = "single"  # float
    DOUBLE = "double"


class DragFrame(StrEnum):
    """The airflow a ``drag`` law is written in (model/forceair.py)."""
    HEADING = "heading"  # the level heading frame (yaw only)
    BODY = "body"        # the body frame at the measured attitude (tilt included), with rotor drag


PRECISIONS = tuple(p.value for p in Precision)  # the words, as the command line and the files spell them
DRAG_FRAMES = tuple(f.value for f in DragFrame)
