"""Help text that stands on its own: every option's help ends with its default.

argparse's ArgumentDefaultsHelpFormatter skips options whose help is missing or whose default is None,
and repeats a default the text already states; this one states the default exactly once for every
option, so an option added later without a word on its default still shows one."""
from __future__ import annotations

import argparse

_NONE_TEXT = "none"


def _default_text(action: argparse.Action) -> str:
    default = action.default
    if isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction)):
        return "on" if default else "off"
    if default is None or (isinstance(default, (list, tuple)) and not default):
        return _NONE_TEXT   # an empty list: a repeatable option given no times
    if isinstance(default, (list, tuple)):
        return " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in default)
    return f"{default:g}" if isinstance(default, float) else str(default)


class DefaultsFormatter(argparse.RawDescriptionHelpFormatter):
    """Appends "(default: X)" to each optional argument whose help does not already name its default."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if not action.option_strings or action.required or action.default is argparse.SUPPRESS:
            return text
        if "default" in text.lower():
            return text
        return f"{text} (default: {_default_text(action)})".strip()
