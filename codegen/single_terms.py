"""Refusing, before generating, a term the single-precision C cannot evaluate within verify's tolerance.

Its own module so that `replay --backend c` checks it without importing the generator (30-80 ms)."""
from __future__ import annotations

from dobwind.model.airframe import Airframe
from dobwind.model.errors import InputError
from dobwind.model.terms import single_precision_problem


def refuse_ill_conditioned_terms(af: Airframe, source: str) -> None:
    """A term whose float evaluation cannot meet verify's single-precision tolerance is refused here,
    with its reason, rather than generated and then failing verify."""
    for table, model in (("horizontal", af.horizontal), ("vertical", af.vertical)):
        for term in model.terms:
            problem = single_precision_problem(term)
            if problem is not None:
                raise InputError(source, f"force_air.{table}.terms",
                                 f"term '{term.text}' cannot be generated in single precision: {problem}")
