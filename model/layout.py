"""Named, ordered slices of a flat vector: the step's inputs, state and outputs.

The same layout names the C struct members and the columns of the Python reference's arrays, so the
two can never disagree on what lives where.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Field:
    name: str   # C member path, e.g. "vel_ned" or "last.wind_ned"
    size: int
    unit: str
    doc: str


@dataclass(frozen=True)
class Layout:
    fields: tuple[Field, ...]

    @property
    def size(self) -> int:
        return sum(f.size for f in self.fields)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.fields)

    def field(self, name: str) -> Field:
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(name)

    def offset(self, name: str) -> int:
        start = 0
        for f in self.fields:
            if f.name == name:
                return start
            start += f.size
        raise KeyError(name)

    def slice(self, name: str) -> slice:
        start = self.offset(name)
        return slice(start, start + self.field(name).size)

    def __contains__(self, name: str) -> bool:
        return name in self.names

    def element_names(self) -> list[str]:
        """One name per scalar: 'vel_ned[0]' or 'dt'."""
        out = []
        for f in self.fields:
            out += [f.name] if f.size == 1 else [f"{f.name}[{i}]" for i in range(f.size)]
        return out

    def pack(self, values: dict[str, np.ndarray | float], rows: int | None = None) -> np.ndarray:
        """Columns from named arrays: shape (rows, size), or (size,) when rows is None."""
        shape = (self.size,) if rows is None else (rows, self.size)
        out = np.zeros(shape)
        for f in self.fields:
            value = np.asarray(values[f.name], dtype=float)
            if rows is None:
                out[self.slice(f.name)] = value.reshape(f.size)
            else:
                out[:, self.slice(f.name)] = value.reshape(rows, f.size)
        return out

    def unpack(self, array: np.ndarray) -> dict[str, np.ndarray]:
        array = np.asarray(array)
        return {f.name: array[..., self.slice(f.name)] for f in self.fields}
