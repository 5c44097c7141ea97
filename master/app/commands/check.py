"""`tiltload check REQS LOG...`: requirements (STL) judged on MCAP logs: verdict, robustness, first violation."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from .. import arguments
from ..api.verdict_table import table
from ..errors import UserError

MAGIC = b"\x89MCAP0\r\n"
PASSED, FAILED, UNDECIDED = 0, 1, 3  # exit codes (2: bad input, as every command)


def add_parser(sub) -> None:
    c = sub.add_parser("check", help="judge runs against requirements (STL): PASS / FAIL / INCONCLUSIVE with robustness "
                                     "and the first violation; exit 0 all pass, 1 a FAIL, 3 none failed but not all passed")
    c.add_argument("files", nargs="*", type=Path, metavar="REQS LOG",
                   help="a requirement file (YAML: docs/requirements.md), then one or more MCAP logs; with --formula "
                        "the file may be left out")
    c.add_argument("--formula", action="append", default=[], metavar="'NAME: STL'",
                   help="a requirement without a file, e.g. 'alt: always[0:40] plant.z < 0' (repeatable)")
    c.add_argument("--explain", action="store_true", help="show each requirement's STL (the sugar expanded) and stop")
    c.add_argument("--json", action="store_true", help="the results as JSON on stdout")
    c.add_argument("--report", type=arguments.output_file, default=None, metavar="FILE",
                   help="also write a self-contained HTML report: verdicts, traceability, plots (docs/reports.md)")
    c.set_defaults(func=run)


def _is_log(path: Path) -> bool:
    """Whether the file starts with MCAP's magic (opened as every user file is: never blocking on a FIFO)."""
    from ...engine.user_files import UserFileError, open_binary

    try:
        with open_binary(path) as f:
            return f.read(8) == MAGIC
    except (UserFileError, OSError):
        return False


def gather(files: list[Path], formulas: list[str]):
    """(requirements, logs) from the command line."""
    from ...engine.requirement.files import from_option, load
    from ...engine.user_files import open_binary

    files = list(files)
    reqs = []
    if files and not _is_log(files[0]) and files[0].suffix != ".mcap":
        reqs = load(files.pop(0))
    reqs += [from_option(f) for f in formulas]
    if not reqs:
        raise UserError("no requirements: give a requirement file first, or --formula 'NAME: STL'")
    names = [r.name for r in reqs]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise UserError(f"requirement '{twice[0]}' is given twice (a file's and a --formula's names must differ)")
    for log in files:
        with open_binary(log, "log") as f:  # a log that cannot be read says why, not "not an MCAP log"
            is_log = f.read(8) == MAGIC
        if not is_log:
            raise UserError(f"{log} is not an MCAP log (no MCAP magic at its start)")
    return reqs, files


def run(args: argparse.Namespace) -> int:
    from ...engine.requirement.check import check_log, log_span

    reqs, logs = gather(args.files, args.formula)
    if args.explain:
        for r in reqs:
            origin = f" (from {r.sugar})" if r.sugar else ""
            print(f"{r.name}{origin}: {r.explain()}")
            print(f"  horizon {r.horizon:g} s; signals {', '.join(r.signals)}")
        return 0
    if not logs:
        raise UserError("no log to check: give one or more MCAP logs after the requirements")
    if args.report is not None:  # before judging: a report that cannot be written, or would overwrite an input
        from ..output_folder import writable_file

        writable_file(args.report, "--report", _inputs(args, logs))
    spans = {log: log_span(log) for log in logs}
    longest = max(spans, key=spans.get)
    for r in reqs:
        if r.horizon > spans[longest] + 1e-9:
            raise UserError(f"requirement '{r.name}' looks {r.horizon:g} s ahead, longer than any run given (the longest, "
                            f"{longest}, is {spans[longest]:g} s): no log can decide it")
    per_log = {log: check_log(log, reqs, missing="inconclusive" if len(logs) > 1 else "error") for log in logs}
    everything = [r for results in per_log.values() for r in results]
    for r in reqs:  # a signal in none of the logs is a typo, not a loop without it
        if len(logs) > 1 and all(x.verdict == "INCONCLUSIVE" and "has no signal" in x.why for x in everything if x.name == r.name):
            check_log(logs[0], [r])  # raises, naming the closest signals
    report = [{"log": str(log), "results": [r.to_json() for r in results]} for log, results in per_log.items()]
    if not args.json:
        for log, results in per_log.items():
            print(f"{log}:")
            print("\n".join(table(results)))
    if args.json:
        print(json.dumps({"logs": report}, indent=1, allow_nan=False))  # RFC 8259: to_json names what is not finite
    if args.report is not None:
        _write_report(args.report, reqs, per_log, args.files[0] if args.files and not _is_log(args.files[0]) else None)
    verdicts = {r.verdict for r in everything}
    if verdicts & {"FAIL", "ERROR"}:  # ERROR: the log's run failed or diverged (the run's own exit code: 1)
        return FAILED
    return PASSED if verdicts == {"PASS"} else UNDECIDED


def _inputs(args: argparse.Namespace, logs: list[Path]) -> list[tuple[str, Path]]:
    files = [("the log it judges", log) for log in logs]
    return files + [("the requirement file", f) for f in args.files if f not in logs]


def _write_report(path: Path, reqs, per_log: dict, requirement_file: Path | None) -> None:
    """The HTML report of the logs judged: a test per log, its replay command with the requirement file."""
    from ..evidence import Report, test_of_log, write_report
    from ..evidence.model import environment_of_tests

    tests = [test_of_log(log, results, requirement_file) for log, results in per_log.items()]
    title = f"Requirements {requirement_file.name if requirement_file else '(--formula)'} on {len(tests)} log" + "s" * (len(tests) != 1)
    write_report(Report(title, "check", tests, environment_of_tests(tests), declared=list(reqs)), path,
                 inputs=[("the requirement file", requirement_file)] if requirement_file else None)
    print(f"report: {path}")
