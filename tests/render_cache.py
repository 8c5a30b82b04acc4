"""The generated C of an airframe rendered once per precision in a test module (issue #34).

`check` renders the C in both precisions (dobwind/cli/check.py: to refuse what `generate` refuses), `check
--no-selftest` renders both again, and `generate` renders one of them a third time: test_range_walk.py asks
check then generate at each of its 49 edges, test_airframe_ranges.py check, check --no-selftest and generate
at each corner. A render (codegen.generate.generate_code: the limit rows of model/boundaries.py found by
bisection, the self-test vectors printed, 0.2-0.3 s) is a pure function of the airframe, the precision, the
name it gives in errors and the autopilot target, so a module that asks for ``shared_renders`` renders each
distinct call once; the commands around it (the self-test gate, which compiles and runs what was rendered,
the writing, the exit status) run whole each time.

Only calls that cannot be told apart are shared: the key is the airframe's repr (every field; -0.0 apart from
0.0), the precision, ``source`` and ``target``, and a call given a model of another airframe is never shared.
A refusal (an exception) is never stored: the next call renders again and raises again.
"""
from __future__ import annotations

import dataclasses

import pytest


class RenderMemo:
    """generate_code, computed once per distinct key; ``calls`` and ``computed`` show the sharing."""

    def __init__(self, function):
        self.function, self.results, self.calls, self.computed = function, {}, 0, 0

    def __call__(self, af, precision=None, model=None, source=None, target=None):
        from dobwind.model.kinds import Precision

        self.calls += 1
        precision = Precision.SINGLE if precision is None else precision
        if model is not None and repr(model.airframe) != repr(af):
            return self.function(af, precision, model, source=source, target=target)
        key = (repr(af), precision, source, target)
        if key not in self.results:
            self.computed += 1
            self.results[key] = self.function(af, precision, model, source=source, target=target)
        code = self.results[key]
        return dataclasses.replace(code, files=dict(code.files))  # the caller's own dict of (immutable) texts


@pytest.fixture(scope="module")
def _render_memo() -> RenderMemo:
    from dobwind.codegen import generate

    return RenderMemo(generate.generate_code)


@pytest.fixture
def shared_renders(_render_memo: RenderMemo, monkeypatch: pytest.MonkeyPatch) -> RenderMemo:
    """The module's memo in place of generate_code, for the requesting test only (check and the harness
    import it at call time from its module, generate's writer holds its own name for it)."""
    from dobwind.codegen import generate
    from dobwind.generate import emit

    monkeypatch.setattr(generate, "generate_code", _render_memo)
    monkeypatch.setattr(emit, "generate_code", _render_memo)
    return _render_memo
