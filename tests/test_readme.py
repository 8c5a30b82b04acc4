"""The README is a short front door that stays true: at most 200 lines, every page it links exists, and its
Python example runs as printed."""
from __future__ import annotations

import re

from tests.helpers import ROOT

README = ROOT / "README.md"
MAX_LINES = 200


def _text() -> str:
    return README.read_text(encoding="utf-8")


def test_readme_is_a_short_front_door():
    assert len(_text().splitlines()) <= MAX_LINES


def linked_pages(text: str) -> list[str]:
    """Relative link targets of a markdown text (anchors dropped, web links skipped)."""
    targets = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text)
    return [t for t in targets if "://" not in t]


def test_every_linked_page_exists():
    missing = [t for t in linked_pages(_text()) if not (ROOT / t).exists()]
    assert missing == []


def test_the_link_check_sees_a_missing_page():
    assert linked_pages("see [a](notes/a.md#x) and [b](https://x.org/b.md) and [c](notes/c.md)") == \
        ["notes/a.md", "notes/c.md"]


def test_the_python_example_runs(tmp_path, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", _text(), re.S)
    assert len(blocks) == 1
    monkeypatch.chdir(tmp_path)
    code = blocks[0].replace('"airframes/m300.toml"', repr(str(ROOT / "airframes" / "m300.toml")))
    names: dict = {}
    exec(compile(code, "README.md", "exec"), names)  # noqa: S102 - the README's own example
    assert names["wind_ned"].shape == (names["log"].rows, 3)
    assert names["trusted"].any()


def test_the_slow_table_names_real_tests():
    """A renamed test must not silently drop out of the slow marker (and so into make test-fast)."""
    from tests.conftest import SLOW

    stale = [f"{file}::{name}" for file, names in SLOW.items() for name in names
             if f"def {name}(" not in (ROOT / "tests" / file).read_text(encoding="utf-8")]
    assert stale == []
