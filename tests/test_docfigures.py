"""docs/figures.md is what `make figures` makes from the current code: the numbers every figure shows
and a checksum of every figure's data (not the PNG bytes, which depend on the matplotlib build)."""
from __future__ import annotations

import re

import numpy as np

from tools import docfigures
from tests.helpers import ROOT

PAGE = ROOT / "docs" / "figures.md"


def test_figures_page_is_current():
    """Fails when the code changes a figure's numbers: run `make figures` and commit docs/."""
    assert docfigures.build(None) == PAGE.read_text(encoding="utf-8"), "docs/figures.md is stale: run `make figures`"


def test_every_image_the_page_shows_exists():
    images = re.findall(r"\]\((images/[^)]+)\)", PAGE.read_text(encoding="utf-8"))
    assert len(images) == 10
    for image in images:
        assert (PAGE.parent / image).is_file(), image


def test_the_checksum_sees_a_change_in_the_fifth_digit_only():
    data = [np.array([1.2345, 6.789]), np.array([[0.5, 2.0]])]
    same = [np.array([1.23450001, 6.789]), np.array([[0.5, 2.0]])]
    moved = [np.array([1.2346, 6.789]), np.array([[0.5, 2.0]])]
    assert docfigures._digest(data) == docfigures._digest(same) != docfigures._digest(moved)
