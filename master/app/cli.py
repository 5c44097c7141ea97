"""The `tiltload` command: one subcommand per module of commands/, one place that turns errors into exit codes."""

from __future__ import annotations

import argparse
import os
import sys


def commands() -> tuple:
    """The subcommands' modules, in the help's order. Imported when the parser is built, not with this module: their
    imports take a second or more, and a Ctrl-C in that second must reach entry()'s handler, not print a traceback."""
    from .commands import (
        b2b,
        build,
        bundle,
        campaign,
        campaign_report,
        check,
        compare,
        design,
        falsify,
        formation,
        layout,
        plot,
        reproduce,
        run,
        serve,
        ssp,
        wrap,
    )

    return (build, bundle, design, wrap, run, serve, ssp, formation, reproduce, compare, b2b, check, campaign, campaign_report, falsify,
            layout, plot)


class OneLineParser(argparse.ArgumentParser):
    """A usage error is one line naming the problem (and where help is), not the usage block. No abbreviated long
    options (--token is not --token-file), and an unrecognized option's values are not echoed (they may be secrets)."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs["allow_abbrev"] = False  # every subcommand's parser is of this class too
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        self.exit(2, self.usage_line(self.prog, message) + "\n")

    @staticmethod
    def usage_line(prog: str, message: str) -> str:
        from .user_error import one_line

        return f"{prog}: error: {one_line(_unechoed(message))} (see: {prog} --help)"


def _unechoed(message: str) -> str:
    """argparse's "unrecognized arguments: --token SECRET" without what followed the unknown options."""
    head = "unrecognized arguments: "
    if not message.startswith(head):
        return message
    words = message[len(head):].split()
    options = [w.partition("=")[0] for w in words if w.startswith("-")]
    if not options:
        return message  # stray words, no option: show them
    hidden = len(words) - len(options)
    return head + " ".join(options) + (f" (and {hidden} value{'s' * (hidden > 1)} not shown)" if hidden else "")


def version() -> str:
    """The installed package's version (a source tree run without installing says 0+unknown)."""
    from importlib import metadata

    try:
        return metadata.version("tiltload")
    except metadata.PackageNotFoundError:
        return "0+unknown"


def parser(cls: type[argparse.ArgumentParser] = OneLineParser) -> argparse.ArgumentParser:
    """The command's parser (cls: its class, inherited by the subcommands')."""
    p = cls(prog="tiltload", description="Build the tiltload FMUs, run the thesis's loop and more.")
    p.add_argument("--version", action="version", version=f"tiltload {version()}", help="print tiltload's version and exit")
    sub = p.add_subparsers(dest="command", required=True)
    for command in commands():
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
        # what an interrupted campaign leaves (Dask's futures) is collected after its event loop closed: their __del__'s
        # complaint ("Exception ignored in ...", a traceback) is no news to whoever pressed Ctrl-C
        sys.unraisablehook = lambda unraisable: None
        return 130
    except BrokenPipeError:  # the reader of our output went away (e.g. `| head`): stop, as a pipe writer does
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        print("tiltload: stopped: standard output was closed (broken pipe)", file=sys.stderr)
        return 141
    except Exception as err:
        from .errors import kind_of, line_of
        from .user_error import one_line

        kind = kind_of(err)  # the one table of errors (errors.py): the user's to fix, a failed build
        if kind is not None:
            print(line_of(err), file=sys.stderr)  # a user's value in it may hold a newline: line_of shows it escaped
            return getattr(err, "exit_code", kind.exit_code)  # a TiltloadError says its kind's code (a failed build: 1)
        if os.environ.get("TILTLOAD_DEBUG"):  # one line for the user; TILTLOAD_DEBUG=1 shows the traceback
            raise
        print(f"tiltload: error: unexpected failure, a bug ({one_line(str(err))[:300]}); TILTLOAD_DEBUG=1 shows where",
              file=sys.stderr)
        return 1


def entry() -> None:
    """The `tiltload` command: main(), then an exit that a loaded pythonfmu controller cannot crash."""
    try:  # from the first import: a Ctrl-C while the command's modules load is as quiet as one while it runs
        from ..engine.fmi.pythonfmu_guard import exit_now, pinned
        from ..engine.run import terminate_like_interrupt

        terminate_like_interrupt()
        code = main()
    except KeyboardInterrupt:
        print("tiltload: interrupted", file=sys.stderr)
        sys.exit(130)
    if pinned():
        exit_now(code)
    sys.exit(code)


if __name__ == "__main__":
    entry()
