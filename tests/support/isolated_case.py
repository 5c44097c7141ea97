"""One bad-input case run as the `tiltload` command runs: in a process of its own, in a session (and so a process group)
of its own, with TMPDIR a fresh empty folder; afterwards, what it left: files in that folder, live processes of its
group. The process is a fork of the caller, so that a case costs its command's time, not an interpreter's start and
tiltload's imports (over a thousand cases), and so that a test's monkeypatches reach it.

No tiltload import here: benchmarks/bad_input_census.py loads this file by path into another tiltload's interpreter
(the pre-milestone commit's) and runs the same cases there. Linux only (the group is read from /proc).
"""

from __future__ import annotations

import atexit
import os
import re
import shutil
import signal
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

GRACE_S = 10.0  # a group's stragglers (a resource tracker ends when its pipe closes) have this long to go


@dataclass
class Outcome:
    code: int | None  # the exit code; None when the case was killed at its timeout (a hang)
    out: str
    err: str
    left_files: list[str] = field(default_factory=list)  # what the case left in its TMPDIR
    left_processes: list[str] = field(default_factory=list)  # its group's processes alive after it ended ("pid name")

    @property
    def left_behind(self) -> str:
        """One line saying what the case left behind, or "" (nothing)."""
        parts = []
        if self.left_files:
            parts.append(f"{len(self.left_files)} in TMPDIR ({', '.join(sorted(self.left_files)[:3])})")
        if self.left_processes:
            parts.append(f"{len(self.left_processes)} process(es) alive ({', '.join(self.left_processes[:3])})")
        return "; ".join(parts)


def group_members(pgid: int) -> list[str]:
    """The live processes (not zombies) whose process group or session is pgid, as "pid name"."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:  # gone meanwhile
            continue
        name, rest = stat[stat.index("(") + 1: stat.rindex(")")], stat[stat.rindex(")") + 2:].split()
        state, pgrp, session = rest[0], int(rest[2]), int(rest[3])
        if state != "Z" and pgid in (pgrp, session):
            found.append(f"{entry} {name}")
    return found


def _child(call, scratch: str, out_fd: int, err_fd: int, cwd: str | None) -> None:
    """In the fork: a session of its own, the fresh TMPDIR, output to the files; the call; the exit a command makes."""
    code = 1
    try:
        os.setsid()
        os.environ["TMPDIR"] = scratch
        tempfile.tempdir = None  # computed again from TMPDIR on first use
        devnull = os.open(os.devnull, os.O_RDONLY)
        os.dup2(devnull, 0)
        os.dup2(out_fd, 1)
        os.dup2(err_fd, 2)
        sys.stdin = open(0, closefd=False)  # noqa: SIM115 (the process's own standard streams, for its life)
        sys.stdout = open(1, "w", closefd=False, buffering=1)  # noqa: SIM115
        sys.stderr = open(2, "w", closefd=False, buffering=1)  # noqa: SIM115
        signal.signal(signal.SIGINT, signal.default_int_handler)
        if cwd is not None:
            os.chdir(cwd)
        result = call()
        code = result if isinstance(result, int) else 0
    except SystemExit as exit_:
        code = exit_.code if isinstance(exit_.code, int) else (0 if exit_.code is None else 1)
        if isinstance(exit_.code, str):
            print(exit_.code, file=sys.stderr)
    except BaseException:  # noqa: BLE001 (what Python itself prints for an uncaught exception, and its exit code)
        traceback.print_exc()
        code = 1
    finally:
        try:
            atexit._run_exitfuncs()  # noqa: SLF001 (what the interpreter runs at its exit: tempfile's finalizers among them)
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def run_isolated(call, *, timeout_s: float = 300.0, cwd: str | Path | None = None) -> Outcome:
    """call() (a command's entry, returning its exit code or raising SystemExit) in a fork of this process, its own
    session, TMPDIR a fresh empty folder; killed with its group at timeout_s. Whatever its group left alive is killed
    after it is counted, and its TMPDIR removed after it is listed, so that one case cannot spoil the next."""
    scratch = tempfile.mkdtemp(prefix="case-tmpdir-")
    with tempfile.TemporaryFile() as out_file, tempfile.TemporaryFile() as err_file:
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            _child(call, scratch, out_file.fileno(), err_file.fileno(), None if cwd is None else str(cwd))
        end = time.monotonic() + timeout_s
        code: int | None = None
        while True:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                code = os.waitstatus_to_exitcode(status)
                code = 128 - code if code < 0 else code  # killed by signal N: 128 + N, as a shell says
                break
            if time.monotonic() > end:
                _kill_group(pid)
                os.waitpid(pid, 0)
                break
            time.sleep(0.005)
        alive = group_members(pid)
        grace_end = time.monotonic() + GRACE_S
        while alive and time.monotonic() < grace_end:
            time.sleep(0.1)
            alive = group_members(pid)
        if alive:
            _kill_group(pid)
            for member in alive:  # one that made a group of its own is still of the case's session
                _kill(int(member.split()[0]))
        left = sorted(os.listdir(scratch))
        while left and time.monotonic() < grace_end:  # an unpacked FMU's reaper (its own session) removes the copy of
            time.sleep(0.05)  # a process that died, once it sees its pipe close: a moment later on a loaded machine
            left = sorted(os.listdir(scratch))
        shutil.rmtree(scratch, ignore_errors=True)
        out_file.seek(0)
        err_file.seek(0)
        return Outcome(code, out_file.read().decode(errors="replace"), err_file.read().decode(errors="replace"), left, alive)


def _kill_group(pgid: int) -> None:
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def _kill(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def tiltload_entry(argv: list[str]):
    """The `tiltload` console script's own entry with argv (it ends in SystemExit with the command's code)."""
    from tiltload.master.app.cli import entry

    sys.argv = ["tiltload", *argv]
    return entry()


def command_exit_code(argv: list[str], timeout_s: float = 300.0) -> int | None:
    """`tiltload argv` run by run_isolated, its output written on this process's streams (where a test's capsys reads
    it), and what it left behind, or its hang, as one more line on stderr, which every one-line check counts."""
    outcome = run_isolated(lambda: tiltload_entry(argv), timeout_s=timeout_s)
    sys.stdout.write(outcome.out)
    sys.stderr.write(outcome.err)
    if outcome.code is None:
        sys.stderr.write(f"hang: killed after {timeout_s:g} s\n")
    if outcome.left_behind:
        sys.stderr.write(f"left behind: {outcome.left_behind}\n")
    return outcome.code


def api_call(call) -> int:
    """An API call as a case: 2 and its one line on stderr when it raises TiltloadError or TypeError (what a user can
    fix), 0 when it returns; anything else propagates (a traceback, exit 1)."""
    import tiltload as tl

    try:
        call()
    except (tl.TiltloadError, TypeError) as err:
        print(f"{type(err).__name__}: {err}" if isinstance(err, TypeError) else str(err), file=sys.stderr)
        return 2
    return 0


EXCEPTION_NAME = re.compile(r"\b[A-Z][A-Za-z]*(Error|Exception|Exit|Interrupt)\b\s*:")


def case_problems(cases, capsys, exception_names: bool = False) -> list[str]:
    """Generated bad-input cases (cls, label, argv or None, API code or None, _), each isolated (its own session and
    TMPDIR): the problems, a case that did not end in one line and exit 2, or whose line is a traceback, "a bug" or
    (unless exception_names: an API's TypeError, a user's own exception quoted) an exception's name."""
    import tiltload as tl

    problems = []
    for cls, label, argv, api, _ in cases:
        if argv is not None:
            code = command_exit_code(argv)
            lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        else:
            outcome = run_isolated(lambda a=api: api_call(lambda: exec(a, {"tl": tl})))  # noqa: S102 (the case's own code)
            code, lines = outcome.code, [ln for ln in outcome.err.splitlines() if ln.strip()]
            if outcome.left_behind:
                lines.append(outcome.left_behind)
        if code != 2 or len(lines) != 1 or "a bug" in lines[0] or "Traceback" in lines[0] or \
                (not exception_names and EXCEPTION_NAME.search(lines[0])):
            problems.append(f"{cls}: {label}: exit {code}: {lines[-3:]}")
    return problems
