"""Solve a cvxpy semidefinite program: SDPA first, Clarabel when SDPA cannot give a usable point.

SDPA is a Schur-complement interior-point solver: it works in the ~2000 decision variables of
the mixed H2/H-infinity problem, where Clarabel factors a KKT system dense in the 3160 triangle
entries of the 79x79 H-infinity LMI. Measured on the thesis's mixed design (2 cores): SDPA 9 s,
Clarabel 75-90 s. SDPA runs in a child process and writes one line per iteration to a file, which the
parent reads so the caller can show real progress. The caller checks the returned point itself (LMI eigenvalues, poles):
a status is never trusted on its own.
"""

from __future__ import annotations

import contextlib
import io
import os
import pickle
import re
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass, field

import cvxpy as cp

# Stop at 1e-6 relative gap (SDPA's default, 1e-7, costs ~8 more iterations and ends
# "optimal_inaccurate" on this problem); 1 vs 2 threads give bit-identical points.
SDPA_OPTIONS = dict(epsilonStar=1e-6, epsilonDash=1e-6, maxIteration=100)
CLARABEL_OPTIONS = dict(max_iter=500, tol_gap_abs=1e-7, tol_gap_rel=1e-7, tol_feas=1e-7, static_regularization_constant=1e-7)
_ITERATION = re.compile(r"^\s*(\d+)\s+([0-9.]+e[+-]\d+)\s")  # "12 3.1e+01 3.4e-06 ..." (iteration, mu)
# the end of SDPA's log: "phase.value  = pdFEAS", "relative gap = +1.2e-06", "p.feas.error = ...", "d.feas.error = ..."
_SUMMARY = {"phase.value": "phase", "relative gap": "relative_gap", "p.feas.error": "primal_infeasibility",
            "d.feas.error": "dual_infeasibility"}
INFEASIBLE = {cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE, cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE}


class SolverFailed(Exception):
    """The solver raised or returned no point."""


@dataclass(frozen=True)
class Solved:
    solver: str
    status: str
    iterations: int
    seconds: float
    summary: dict = field(default_factory=dict)  # SDPA: its phase and where it stopped (docs/controller.md)


def sdpa_available() -> bool:
    return "SDPA" in cp.installed_solvers()


def solve_sdpa(problem: cp.Problem, on_iteration=None, threads: int | None = None) -> Solved:
    """SDPA in a child process (it holds the GIL, and a crash must not take the caller down),
    its per-iteration log tailed into on_iteration(iteration, mu, seconds)."""
    threads = threads or int(os.environ.get("TILTLOAD_SOLVER_THREADS", 0)) or max(1, min(4, os.cpu_count() or 1))
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data, chain, inverse_data = problem.get_problem_data(cp.SDPA)
    options = dict(SDPA_OPTIONS, numThreads=threads)
    with tempfile.TemporaryDirectory(prefix="tiltload_sdpa_") as tmp:
        job, result, log = (os.path.join(tmp, f) for f in ("job.pickle", "result.pickle", "sdpa.log"))
        with open(job, "wb") as f:
            pickle.dump((data, options), f)
        open(log, "w").close()
        child = subprocess.Popen([sys.executable, "-m", __name__, job, result, log],
                                 stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        seen = 0
        try:
            with open(log) as f:
                while True:
                    running = child.poll() is None
                    for line in f.readlines():  # SDPA flushes one line per iteration
                        m = _ITERATION.match(line)
                        if m:
                            seen = int(m.group(1)) + 1
                            if on_iteration is not None:
                                on_iteration(seen, float(m.group(2)), time.perf_counter() - start)
                    if not running:
                        break
                    time.sleep(0.2)
        finally:
            if child.poll() is None:  # interrupted: stop the solver with us
                child.kill()
            stderr = child.communicate()[1].decode(errors="replace").strip().splitlines()
        if child.returncode != 0 or not os.path.exists(result):
            why = stderr[-1] if stderr else f"exit status {child.returncode}"
            raise SolverFailed(f"SDPA failed: {why}")
        with open(result, "rb") as f:
            solution = pickle.load(f)
        with open(log) as f:
            summary = _summary(f.read())
    with warnings.catch_warnings():  # "inaccurate" is judged by the caller, at the point itself
        warnings.simplefilter("ignore")
        problem.unpack_results(solution, chain, inverse_data)
    return Solved("SDPA", str(problem.status), seen, time.perf_counter() - start, summary)


def _summary(log: str) -> dict:
    """SDPA's closing lines: the phase it ended in (pdOPT: the gap criterion met; pdFEAS: primal and dual feasible,
    stopped before it), the relative gap and the feasibility errors at the point."""
    out = {}
    for line in log.splitlines():
        key, sep, value = line.partition("=")
        name = _SUMMARY.get(key.strip())
        if sep and name:
            value = value.strip()
            try:
                out[name] = float(value)
            except ValueError:
                out[name] = value
    return out


def _child(job: str, result: str, log: str) -> None:
    """Child side: solve the pickled SDPA data, pickle cvxpy's solution."""
    from cvxpy.reductions.solvers.conic_solvers.sdpa_conif import SDPA

    with open(job, "rb") as f:
        data, options = pickle.load(f)
    # sdpap prints a banner and an ARPACK note to Python's stdout; cvxpy warns on "inaccurate"
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        solution = SDPA().solve_via_data(data, False, False, dict(options, print=log))
    with open(result + ".tmp", "wb") as f:
        pickle.dump(solution, f)
    os.replace(result + ".tmp", result)


def solve_clarabel(problem: cp.Problem) -> Solved:
    start = time.perf_counter()
    try:
        problem.solve(solver=cp.CLARABEL, **CLARABEL_OPTIONS)
    except cp.error.SolverError as err:
        raise SolverFailed(f"Clarabel failed: {err}") from None
    iterations = getattr(problem.solver_stats, "num_iters", None) or 0
    return Solved("Clarabel", str(problem.status), int(iterations), time.perf_counter() - start)


if __name__ == "__main__":
    try:
        _child(*sys.argv[1:4])
    except Exception as err:  # noqa: BLE001 - reported to the parent as one line on stderr
        print(f"{type(err).__name__}: {err}", file=sys.stderr)
        sys.exit(1)
