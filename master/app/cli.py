"""The `tiltload` command: one subcommand per module of commands/, one place that turns errors into exit codes."""

from __future__ import annotations

import argparse
import os
import sys

from .commands import build, campaign, compare, design, falsify, formation, layout, plot, reproduce, run, serve, ssp, wrap

COMMANDS = (build, design, wrap, run, serve, ssp, formation, reproduce, compare, campaign, falsify, layout, plot)  # in the help's order


class OneLineParser(argparse.ArgumentParser):
    """A usage error is one line naming the problem (and where help is), not the usage block."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see: {self.prog} --help)\n")


def parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="tiltload", description="Build the tiltload FMUs, run the thesis's loop and more.")
    sub = p.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        command.add_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run one command; errors become one line on stderr: 2 for the user's to fix, 1 for a build failure or a bug.

    The error classes are imported only when an error happens: they pull in numpy, scipy and CasADi (a second or
    two), and a command should say what it does from its first second."""
    args = parser().parse_args(argv)
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print("tiltload: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of our output went away (e.g. `| head`): stop, as a pipe writer does
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        print("tiltload: stopped: standard output was closed (broken pipe)", file=sys.stderr)
        return 141
    except Exception as err:
        from ...native_fmu.compile import BuildError
        from .errors import USER_ERRORS

        if isinstance(err, USER_ERRORS):
            print(f"tiltload: error: {err}", file=sys.stderr)
            return 2
        if isinstance(err, BuildError):  # the compiler failed or is missing: the environment, not a bug
            print(f"tiltload: error: building the FMUs failed: {err}", file=sys.stderr)
            return 1
        if os.environ.get("TILTLOAD_DEBUG"):  # one line for the user; TILTLOAD_DEBUG=1 shows the traceback
            raise
        print(f"tiltload: error: unexpected failure, a bug ({err!s:.300}); TILTLOAD_DEBUG=1 shows where", file=sys.stderr)
        return 1


def entry() -> None:
    """The `tiltload` command: main(), then an exit that a loaded pythonfmu controller cannot crash."""
    from ..engine.pythonfmu_guard import exit_now, pinned
    from ..engine.run import terminate_like_interrupt

    terminate_like_interrupt()
    code = main()
    if pinned():
        exit_now(code)
    sys.exit(code)


if __name__ == "__main__":
    entry()
