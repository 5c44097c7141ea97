"""The LMI designs the project computed for the default parameters, shipped with tiltload (shipped/*.json).

Without them a first `tiltload run` synthesizes the mixed design for loop delays 0, 1 and 2 (minutes on 2 cores).
A shipped design is used only if (1) it was made on this very problem: the same model A, B, F, weights, trim,
parameters, T_c, regions and prescribed bound, compared entry by entry with the ones computed here; and (2) every
LMI holds at its point (X, P, Y, N, gamma~) evaluated here, and the gain derived here from that point has its poles
in both regions (lmi_check.verify, a few milliseconds). Nothing in the file is trusted: its gain is derived again
from the point, its bounds and norms are computed again. A design that fails either test is not used: the caller
synthesizes instead (and says so).

Regenerate after a change to the model, the weights or the LMIs (a test fails while a shipped design no longer
fits): python -m tiltload.controller_fmu.design.ship
"""

from __future__ import annotations

import os
import platform
import time
from importlib import metadata
from pathlib import Path

import numpy as np

from . import artifact
from .artifact import Design
from .error_dynamics import DesignError
from .lmi_check import EPS_REGION, VARPI_REGION, LMIPoint, lmi_report, verify
from .problems import MIXED_GAMMA_SQ, describe, label, problem

FOLDER = Path(__file__).with_name("shipped")
SHIPPED = (("hinf", 0), ("mixed", 0), ("mixed", 1), ("mixed", 2))  # (kind, loop delay) of the load vehicle, T_c 12 ms
TC = 0.012
MATCH_RTOL, MATCH_ATOL = 1e-9, 1e-12  # the same problem up to rounding (other BLAS kernels move the last bits)


def path(kind: str, vehicle: str = "load", loop_delay: int = 0) -> Path:
    return FOLDER / f"{label(kind, vehicle, loop_delay)}.json"


def find(kind: str, Tc: float, vehicle: str = "load", loop_delay: int = 0, progress=None) -> Design | None:
    """The shipped design of this kind, checked on this model; None if there is none or it does not hold here."""
    file = path(kind, vehicle, loop_delay)
    if kind == "dlqr" or not file.is_file() or os.environ.get("TILTLOAD_SHIPPED_DESIGNS") == "0":
        return None  # TILTLOAD_SHIPPED_DESIGNS=0: synthesize as a machine without them would (benchmarks/baseline_spread.py)
    say = progress or (lambda _: None)
    started = time.perf_counter()
    try:
        stored = artifact.load(file, origin="shipped")
        sys, Q, R = problem(kind, Tc, vehicle, loop_delay)
        mismatch = _mismatch(stored, kind, sys, Q, R, Tc, loop_delay)
        if mismatch:
            say(f"the shipped {describe(kind, loop_delay)} was made on another problem ({mismatch}): not used")
            return None
        if stored.lmi_point is None:
            raise DesignError("it carries no LMI point to check")
        checking = time.perf_counter()
        res = verify(sys, Q, R, LMIPoint.from_json(stored.lmi_point), mixed=kind == "mixed", measure_norms=False)
        checked = time.perf_counter() - checking
    except (ValueError, DesignError) as err:  # DesignError is a ValueError; a malformed file too
        say(f"the shipped {describe(kind, loop_delay)} is refused ({err}): not used")
        return None
    original = stored.report
    report = {**lmi_report(res), "hinf_norm": None, "h2_norm": None,  # measured on demand (measured_norms: ~0.3 s)
              "solver": original.get("solver"), "solver_status": original.get("solver_status"),
              "solver_iterations": original.get("solver_iterations"), "solver_summary": original.get("solver_summary"),
              "solver_seconds": original.get("solver_seconds"),
              "synthesis_machine": original.get("synthesis_machine"), "gain_norm": float(np.linalg.norm(res.K, 2)),
              "seconds": original.get("seconds"), "check_seconds": checked, "load_seconds": time.perf_counter() - started}
    say(f"{describe(kind, loop_delay)}: the shipped one, checked on this model in {report['check_seconds'] * 1e3:.0f} ms "
        f"(every LMI holds at its point, smallest eigenvalue {min(res.lmi_min_eig.values()):.1e}; poles in both regions)")
    return Design(kind, res.K, Tc, sys.trim.x, sys.trim.u, sys.params, sys.A, sys.B, sys.F, Q, R, report, loop_delay,
                  stored.lmi_point, origin="shipped")


def _mismatch(stored: Design, kind: str, sys, Q, R, Tc: float, loop_delay: int) -> str | None:
    """What differs between the stored design's problem and this one (None: the same problem)."""
    if stored.kind != kind or stored.loop_delay != loop_delay or stored.Tc != Tc:
        return f"{stored.kind}, d = {stored.loop_delay}, T_c = {stored.Tc} s"
    regions = stored.report.get("regions", {})
    if regions.get("eps") != EPS_REGION or regions.get("varpi") != VARPI_REGION:
        return f"regions {regions}"
    if kind == "mixed" and (stored.lmi_point or {}).get("gamma_sq") != MIXED_GAMMA_SQ:
        return f"gamma~ {(stored.lmi_point or {}).get('gamma_sq')} instead of {MIXED_GAMMA_SQ:g}"
    here = {"A": sys.A, "B": sys.B, "F": sys.F, "omega_chi": Q, "omega_u": R, "params": sys.params,
            "trim_x": sys.trim.x, "trim_u": sys.trim.u}
    for name, value in here.items():
        theirs = getattr(stored, name)
        if theirs.shape != np.shape(value) or not np.allclose(theirs, value, rtol=MATCH_RTOL, atol=MATCH_ATOL):
            return f"its {name} differs from the one computed here"
    return None


def machine() -> str:
    """This machine in one line (CPU model, cores, the solver stack), recorded with each shipped design."""
    cpu = platform.processor() or platform.machine()
    try:
        cpu = next(line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                   if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    versions = ", ".join(f"{d} {_version(d)}" for d in ("sdpa-python", "cvxpy", "numpy", "scipy", "casadi"))
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}; {versions}"


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "none"
