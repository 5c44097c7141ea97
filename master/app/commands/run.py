"""`tiltload run`: the main job. The command line read into a Case and RunOptions, run by the API's core
(api/execute.py, as tiltload.run runs it), its lines printed and its outcome the exit code."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import arguments
from ..case.fields import CASE, RUN


def add_parser(sub) -> None:
    r = sub.add_parser("run", help="main job: run the closed loop through the FMUs, log to MCAP, print ISE/IADU, plot")
    arguments.add_loop_options(r)
    r.add_argument("--schedule", **CASE.option("schedule"), default=None,
                   help="ordered: tiltload's master (default); jacobi: as libcosim and Ecos step (a package's own choice "
                        "is the default for it)")
    r.add_argument("--out", **RUN.option("out"), default=Path("runs"), help="where the log and plots go (default: runs)")
    r.add_argument("--name", **RUN.option("name"), default=None, help="file name stem of the log")
    r.add_argument("--trust-fmus", action="store_true",
                   help="run every FMU inside this process (default: FMUs tiltload did not build run each in its own "
                        "process, so a crash, exit() or hang in one ends the run with one line)")
    r.add_argument("--step-timeout", **RUN.option("step_timeout"), default=None, metavar="S",
                   help=f"watchdog for an FMU in its own process: the longest a call may take (default 10 s; at most "
                        f"{arguments.DAY:g} s)")
    r.add_argument("--profile", action="store_true",
                   help="say where the ticks' time went: each FMU's step time (min, median, p99, max) and share, the "
                        "isolation's, the master's, the log's, and the real-time margin (docs/master.md)")
    r.add_argument("--token-file", type=Path, default=None, metavar="FILE",
                   help="the shared secret of the tiltload serve a --remote instance runs on (docs/remote.md)")
    r.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    r.add_argument("--no-log", action="store_true", help="no MCAP log: metrics only (campaigns); implies --no-plots")
    r.add_argument("--log-every", **RUN.option("log_every"), default=1, metavar="N",
                   help="log every N-th step of each FMU (default 1: every step)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.add_argument("--requirements", type=Path, default=None, metavar="REQS",
                   help="monitor these requirements (STL, YAML: docs/requirements.md) while the run goes: verdicts in the "
                        "table and the log")
    r.add_argument("--report", **RUN.option("report"), default=None, metavar="FILE",
                   help="write a self-contained HTML report of the run: its requirements' verdicts with their signals "
                        "plotted, the environment (FMU digests, the controller's parameters), the command that replays it "
                        "(docs/reports.md)")
    r.add_argument("--stop-on-violation", action="store_true",
                   help="with --requirements: end the run once a requirement's FAIL can no longer change")
    r.add_argument("--snapshot-at", nargs=2, metavar=("T", "FILE"), default=None,
                   help="at t = T s write every FMU's state and the master's to FILE (the run goes on)")
    r.add_argument("--from-snapshot", type=Path, default=None, metavar="FILE",
                   help="continue the run a snapshot was taken of (with --faults, --set of tunable parameters, --stop-time)")
    r.add_argument("--realtime", **RUN.option("realtime"), nargs="?", const=1.0, default=None, metavar="FACTOR",
                   help=f"pace the ticks against the monotonic clock, FACTOR x real time (default 1; from "
                        f"{1 / arguments.MAX_REALTIME_FACTOR:g} to {arguments.MAX_REALTIME_FACTOR:g}); overruns are reported")
    r.add_argument("--max-overruns", **RUN.option("max_overruns"), default=None, metavar="N",
                   help="with --realtime: stop the run once more than N ticks missed their deadline")
    r.add_argument("--expect-fmu", **RUN.option("expect_fmu"), action="append", default=[], metavar="INSTANCE=SHA256",
                   help="refuse the run (exit 2) unless INSTANCE runs the FMU of this SHA-256 (a replay names the build it "
                        "replays: a rebuild at the same path is another controller)")
    r.set_defaults(func=run)


# the options of `tiltload run` that say how the case runs (the rest of its options are the Case's)
RUN_OPTIONS = ("out", "name", "no_log", "no_plots", "log_every", "requirements", "stop_on_violation", "snapshot_at",
               "from_snapshot", "realtime", "max_overruns", "trust_fmus", "step_timeout", "token_file", "quiet", "report", "expect_fmu",
               "profile")


def case_of(args: argparse.Namespace):
    """The Case the command line describes (the same object tiltload.run builds from its keywords)."""
    from dataclasses import fields

    from ..api.case import Case

    given = {f.name: getattr(args, f.name) for f in fields(Case) if hasattr(args, f.name)}
    return Case(**{**given, "set": tuple(args.set), "remote": tuple(args.remote),
                   "input_file": tuple(getattr(args, "input_file", ()))})


def run_options_of(args: argparse.Namespace):
    """The RunOptions of the command line."""
    from ..api.run_options import RunOptions

    given = {name: getattr(args, name) for name in RUN_OPTIONS}
    return RunOptions(**{**given, "snapshot_at": None if args.snapshot_at is None else tuple(args.snapshot_at),
                         "expect_fmu": tuple(args.expect_fmu)})


def run(args: argparse.Namespace) -> int:
    from ..api.execute import preparing

    if not args.quiet:  # before the imports (numpy, CasADi, FMPy: seconds): the user sees at once that it started
        print(preparing(args, args), flush=True)
    from ..api.execute import execute
    from ..api.python_controller import is_python_file
    from ..wrap.class_fmu import wrapped_line

    case = case_of(args)
    if is_python_file(args.controller) and not args.quiet:  # wrapped on the fly: say how
        print(f"--controller {wrapped_line(args.controller, case.controller)}", flush=True)
    outcome = execute(case, run_options_of(args), print)
    if outcome.failure is not None:
        print(f"tiltload: error: {outcome.failure}", file=sys.stderr)
    return outcome.code
