"""One module per command (issue #34): each subcommand's arguments and its run live in
dobwind/cli/<command>.py, and the parser's assembly (app.py) holds no command of its own."""
from __future__ import annotations

import argparse
import ast
import functools
from pathlib import Path

from dobwind.cli.app import build_parser

ROOT = Path(__file__).resolve().parents[1]


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def misplaced(parser: argparse.ArgumentParser) -> list[str]:
    """Subcommands whose handler is not ``run`` of dobwind.cli.<name> (a partial is unwrapped)."""
    bad = []
    for name, sub in _subcommands(parser).items():
        func = sub.get_default("func")
        while isinstance(func, functools.partial):
            func = func.func
        if (getattr(func, "__module__", None), getattr(func, "__name__", None)) != (f"dobwind.cli.{name}", "run"):
            bad.append(f"{name}: {getattr(func, '__module__', None)}.{getattr(func, '__name__', None)}")
    return bad


def test_each_command_runs_from_its_own_module():
    assert misplaced(build_parser()) == []


def test_the_check_sees_a_command_run_from_elsewhere():
    parser = build_parser()
    _subcommands(parser)["check"].set_defaults(func=print)  # a handler that is not dobwind.cli.check.run
    assert misplaced(parser) == ["check: builtins.print"]


def test_the_assembly_defines_no_command():
    """app.py: the parser's class, --version, the assembly and the dispatch; no `cmd_*` or `_add_*`."""
    tree = ast.parse((ROOT / "dobwind" / "cli" / "app.py").read_text(encoding="utf-8"))
    names = {node.name for node in tree.body if isinstance(node, (ast.FunctionDef, ast.ClassDef))}
    assert [n for n in names if n.startswith(("cmd_", "_add_"))] == []
    assert {"build_parser", "main"} <= names
