"""The ``dobwind`` command line: the top-level parser, one subcommand per module (dobwind/cli/<command>.py,
each with its ``add`` and ``run``), and the dispatch that turns every failure into its exit status.

Every user mistake ends as one stderr line and exit status 2; a failed check as exit status 1.
"""
from __future__ import annotations

import argparse
import errno
import os
import re
import sys
from typing import NoReturn, Sequence

from dobwind.cli import analyze, check, demo, fit, generate, init, inspect, profile, replay, report, simulate, verify
from dobwind.cli.common import Command
from dobwind.cli.helpfmt import DefaultsFormatter
from dobwind.core.errors import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, CheckFailed, InputError
from dobwind.core.interrupts import Interrupted, signals_raise
from dobwind.core.version import package_version

EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what a shell reports for a C tool killed by the closed pipe


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, not argparse's usage block
        sys.stderr.write(f"{self.prog}: error: {message} (see --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)

    def parse_known_args(self, args=None, namespace=None):  # type: ignore[no-untyped-def]
        return super().parse_known_args(attach_dash_values(sys.argv[1:] if args is None else list(args)), namespace)


def attach_dash_values(argv: list[str]) -> list[str]:
    """`--wind -2@90`: argparse takes a value that starts with a dash for an option unless it is a plain
    negative number, and says only "expected one argument". No dobwind option starts with a digit, so such
    a token after a long option is its value: given as `--wind=-2@90`, the option's own check says what is
    wrong with it ("the speed -2 m/s must be in [0, 100] m/s"). Plain negative numbers are left to argparse,
    which takes them as values already, also for an option of several values (`--freq -1 2`)."""
    out: list[str] = []
    for token in argv:
        previous = out[-1] if out else ""
        if (_DASH_VALUE.match(token) and not _PLAIN_NEGATIVE.match(token) and previous.startswith("--")
                and "=" not in previous and previous != "--"):
            out[-1] = f"{previous}={token}"
        else:
            out.append(token)
    return out


_DASH_VALUE = re.compile(r"^-\.?[0-9]")
_PLAIN_NEGATIVE = re.compile(r"^-\d+$|^-\d*\.\d+$")  # argparse's own test for a negative number


class _VersionAction(argparse.Action):
    """--version, looked up only when asked: the package metadata costs 45 ms of every other command."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(self, parser, namespace, values, option_string=None) -> None:  # type: ignore[no-untyped-def]
        print(f"dobwind {package_version()}")  # stdout, as argparse's own version action prints
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="dobwind", description="Airframe description -> verified C wind estimator.",
                    formatter_class=DefaultsFormatter)
    parser.add_argument("--version", action=_VersionAction, help="show program's version number and exit")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND")

    def command(name: str, text: str) -> argparse.ArgumentParser:
        return sub.add_parser(name, help=text, description=text, formatter_class=DefaultsFormatter)

    add_commands(command)
    return parser


def add_commands(command: Command) -> None:
    """The subcommands in the order --help lists them."""
    check.add(command)
    generate.add(command)
    verify.add(command)
    analyze.add(command)
    fit.add(command)
    replay.add(command, main)  # its workers run the whole command line on one log each
    simulate.add(command)
    profile.add(command)
    report.add(command)
    demo.add(command)
    inspect.add(command)
    init.add(command)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    with signals_raise() as caught:
        command = "?"
        try:
            args = parser.parse_args(argv)
            command = args.command
            _refuse_closed_stdout_and_special_files(args)
            status = int(args.func(args))
            if caught.signo is not None:  # its exception was swallowed (CasADi): still a stop
                raise Interrupted(caught.signo)
            sys.stdout.flush()  # inside the try: a reader that went away is reported here, not at exit
            return status
        except InputError as exc:
            sys.stderr.write(f"dobwind {command}: {exc}\n")
            return EXIT_BAD_INPUT
        except CheckFailed as exc:
            sys.stderr.write(f"dobwind {command}: {exc}\n")
            return EXIT_CHECK_FAILED
        except BrokenPipeError:
            return _reader_went_away()
        except OSError as exc:  # a write that failed outside the atomic writers: stdout on a full disk
            if caught.signo is not None:
                raise
            where = exc.filename or ("stdout" if exc.errno in _WRITE_ERRNOS else "error")
            sys.stderr.write(f"dobwind {command}: {where}: {exc.strerror or exc}\n")
            _reader_went_away()  # the buffered rest would fail again at exit
            return EXIT_BAD_INPUT
        except BaseException:
            if caught.signo is None:
                raise
            # The `with` blocks on the way out have removed every temporary; earlier outputs are untouched.
            sys.stderr.write(f"dobwind {command}: stopped by {caught.name}; no partial output left\n")
            return 128 + caught.signo


# Errors of a write to an ordinary stream (the OSError then names no file): full disk, quota, I/O, closed.
_WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EBADF)


def _refuse_closed_stdout_and_special_files(args: argparse.Namespace) -> None:
    from dobwind.io.specialfiles import refuse_special_inputs

    if sys.stdout is None:  # started with fd 1 closed: Python then has no stdout at all
        raise InputError("stdout", None, "is closed; run with an open standard output (e.g. >/dev/null)")
    refuse_special_inputs(args)


def _reader_went_away() -> int:
    """`dobwind ... | head`: the reader closed the pipe, which is not an error worth a traceback.

    Python flushes stdout again at exit and would report the same broken pipe there, so stdout is
    pointed at /dev/null first (the usual recipe; see the signal module's documentation on SIGPIPE)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout is not a real file (in-process callers): nothing to flush
        pass
    return EXIT_BROKEN_PIPE



if __name__ == "__main__":
    raise SystemExit(main())
