"""Precision and drag frame are enums whose members are the words of the files and the command line
(issue #34): the words stay as they were, a loaded airframe carries the enum, and no module compares
a precision or a frame with a bare string any more."""
from __future__ import annotations

import ast
import dataclasses
import json
from pathlib import Path

import pytest

from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dump_airframe
from dobwind.model.forceair import DragLaw
from dobwind.model.kinds import DRAG_FRAMES, PRECISIONS, DragFrame, Precision
from tests.helpers import M300

ROOT = Path(__file__).resolve().parents[1]
# The words as docs/formats.md and the --precision choices spell them (transcribed, not derived).
PRECISION_WORDS = ("single", "double")
FRAME_WORDS = ("heading", "body")
KIND_WORDS = set(PRECISION_WORDS + FRAME_WORDS)


def test_the_words_are_unchanged():
    assert PRECISIONS == PRECISION_WORDS and DRAG_FRAMES == FRAME_WORDS
    assert [str(p) for p in Precision] == list(PRECISION_WORDS)
    assert all(member == word and hash(member) == hash(word)  # a dict keyed by the word finds the member
               for member, word in zip(DragFrame, FRAME_WORDS))
    assert json.dumps({"precision": Precision.SINGLE, "frame": DragFrame.BODY}) == \
        '{"precision": "single", "frame": "body"}'


def test_a_loaded_law_carries_the_enum_and_writes_the_word():
    law = DragLaw(0.2, 0.08, lz=0.3, qz=0.1, lr=0.1, frame=DragFrame.BODY)
    text = dump_airframe(dataclasses.replace(load_airframe(M300), drag=law))
    assert 'frame = "body"' in text
    loaded = parse_airframe(text, "x.toml").drag
    assert loaded.frame is DragFrame.BODY and loaded == law
    heading = parse_airframe(text.replace('frame = "body"\n', "").replace("lr = 0.1\n", ""), "x.toml").drag
    assert heading.frame is DragFrame.HEADING  # the default, when the file names no frame


def kind_comparisons(path: Path) -> list[str]:
    """`x == "single"`, `x != "body"`, `x in ("heading", ...)`: a kind compared with its bare word."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.Compare):
            continue
        operands = [node.left, *node.comparators]
        words = [c.value for o in operands for c in ([o] if isinstance(o, ast.Constant) else
                                                     o.elts if isinstance(o, (ast.Tuple, ast.List, ast.Set)) else [])
                 if isinstance(c, ast.Constant) and c.value in KIND_WORDS]
        if words:
            found.append(f"{path.name}:{node.lineno} compares with {words[0]!r}")
    return found


def test_no_kind_is_compared_with_a_bare_word():
    files = [p for folder in ("model", "codegen", "harness", "dobwind") for p in sorted((ROOT / folder).rglob("*.py"))]
    assert len(files) > 100
    assert [hit for p in files for hit in kind_comparisons(p)] == []


@pytest.mark.parametrize("code", ['if precision == "single":\n    pass\n', 'x = frame != "body"\n',
                                  'ok = p in ("double", "both")\n'])
def test_the_comparison_check_sees_a_bare_word(tmp_path, code):
    (tmp_path / "m.py").write_text(code)
    assert len(kind_comparisons(tmp_path / "m.py")) == 1
    (tmp_path / "m.py").write_text(code.replace('"single"', "Precision.SINGLE").replace('"body"', "DragFrame.BODY")
                                   .replace('"double"', "Precision.DOUBLE"))
    assert kind_comparisons(tmp_path / "m.py") == []
