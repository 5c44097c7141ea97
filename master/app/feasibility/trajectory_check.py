"""Can the vehicle fly this trajectory? The feedforward and the trim along the reference the scenario FMU outputs.

Two questions at every sample the controller takes (the 12 ms tick):
- the feedforward (3.18) the controller computes, u_tr = L_in^+ (M qdd_tr + (C + L_fr) qd_tr + g) at the reference
  state (the load on the path, the other coordinates at the hover trim of the nominal model, as in
  control_law.StateFeedback), against the actuator limits of Table 5.2 (0 <= f <= 30 N, |tau| <= 2 N m);
- the trim the path needs: the attitude and inputs that carry the load along with the reference's velocity and
  acceleration with every joint at rest (M(q) qdd + C(q, qd) qd + L_fr qd + g(q) = L_in(q) u, the hover trim's
  equations plus the path's motion, solved for phi, theta, gamma_1, gamma_2, alpha_R, alpha_L and u by Newton's
  method, on the plant's own parameters), every 0.12 s: its thrusts against the same limits and its tilt angles
  against max_tilt (30 degrees by default: the controllers are linearized at the hover trim).
A problem names the quantity, the time and the margin: "f_R would need 31.4 N at t = 12.30 s; the limit is 30 N".
(Which systems are checked and what a problem refuses: policy.py; the yaw a design holds: yaw_margin.py.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ....plant_fmu.parameters import ACTUATOR_LIMIT
from ....plant_fmu.vehicles import VEHICLES
from ....scenario_fmu import knot_file, twin
from ....scenario_fmu.waypoints import MAX_TIME as WAYPOINT_MAX_TIME
from ..loop.defaults import MAX_TILT, VEHICLE
from .yaw_margin import yaw_problem

INPUT_NAMES = ("f_R", "f_L", "tau_R", "tau_L")
TRIM_EVERY = 10  # ticks between trim solves (0.12 s)
MAX_SPAN = WAYPOINT_MAX_TIME  # s checked at most: the longest reference a file can describe (a longer --stop-time holds it)
CHUNK = 2**14  # ticks sampled at once: the check's memory is bounded whatever the span


@dataclass(frozen=True)
class Limits:
    f_min: float = ACTUATOR_LIMIT["f_min"]  # N, Table 5.2
    f_max: float = ACTUATOR_LIMIT["f_max"]
    tau_max: float = ACTUATOR_LIMIT["tau_max"]  # N m
    max_tilt: float = MAX_TILT  # degrees, any trim angle (load roll/pitch, UAV tilt to the rod, thruster tilts)


@dataclass
class Report:
    problems: list[str] = field(default_factory=list)  # each one line; any refuses the run
    notes: list[str] = field(default_factory=list)  # worth saying, not refusing (a jump the feedforward cannot see)
    summary: str = ""

    @property
    def ok(self) -> bool:
        return not self.problems




def _trim(vehicle: str, z_prev, ref_prev, ref, p, n_angles: int, depth: int = 0):
    """The trim at ref by Newton (plant_fmu.trim.newton) from the trim at ref_prev, by halving the way when Newton
    strays (a solution far from the previous one is another branch: the vehicle upside down)."""
    from ....plant_fmu.trim import newton
    from .trim_residual import compiled_newton

    solve = compiled_newton(vehicle)  # the same steps in C, the same bits (trim_residual.py)
    found = solve(z_prev, ref, p, 1e-9, 20) if solve is not None else newton(vehicle, z_prev, ref, p, 1e-9, 20)
    if found is not None and np.max(np.abs(found[0][:n_angles] - z_prev[:n_angles])) < 0.3:
        return found[0]
    if depth >= 8:
        return None
    middle = 0.5 * (ref_prev + ref)
    z_mid = _trim(vehicle, z_prev, ref_prev, middle, p, n_angles, depth + 1)
    return None if z_mid is None else _trim(vehicle, z_mid, middle, ref, p, n_angles, depth + 1)


@lru_cache(maxsize=64)
def _hover(vehicle: str, p: bytes):
    """The hover trim of a parameter vector (its bytes), solved once per vector: a search over other inputs checks
    the same plant again and again (read only)."""
    from ....plant_fmu.trim import hover_trim
    from .trim_residual import compiled_newton

    return hover_trim(np.frombuffer(p), vehicle=vehicle, solve=compiled_newton(vehicle))


@lru_cache(maxsize=64)
def _trim_start(vehicle: str, p: bytes) -> np.ndarray:
    """The trims' unknowns at the hover trim of a parameter vector (its bytes): the first trim's start (read only)."""
    from ....plant_fmu.trim import unknown_coordinates

    hover = _hover(vehicle, p)
    z = np.r_[hover.x[unknown_coordinates(vehicle)], hover.u]
    z.flags.writeable = False
    return z


@dataclass
class _Chunk:
    """A chunk of the reference: its samples, the nominal feedforward there and the trims' reference rows, with what
    follows from them alone computed once (a cached chunk is read by every point of a search over the plant or the
    wind)."""

    s: twin.Samples
    u: np.ndarray
    refs: np.ndarray
    _own_jump: tuple | None = None
    _psi: tuple | None = None
    _facts: dict = field(default_factory=dict)

    def jump(self, before, tick: float) -> tuple[float, float, float]:
        """_largest_jump of the chunk (from the chunk before's last sample when there is one)."""
        if before is not None:
            return _largest_jump(self.s, before, tick)
        if self._own_jump is None:
            self._own_jump = _largest_jump(self.s, None, tick)
        return self._own_jump

    def psi_worst(self) -> tuple[float, float, float]:
        """(|psi|, psi, t) at the chunk's largest yaw."""
        if self._psi is None:
            k = int(np.argmax(np.abs(self.s.psi)))
            self._psi = (abs(float(self.s.psi[k])), float(self.s.psi[k]), float(self.s.t[k]))
        return self._psi

    def feedforward_facts(self, limits: Limits, explain: bool = True) -> tuple[list[str], str, float]:
        """For a reference of this one chunk: the feedforward's problems against the limits, its forces' ranges (the
        summary's words) and its largest torque (explain=False: the problems alone, "" and nan)."""
        key = (limits.f_min, limits.f_max, limits.tau_max, explain)
        if key not in self._facts:
            found = Report()
            _limit_inputs(found, "", self.u, self.s.t, limits)
            self._facts[key] = ((found.problems, _forces(self.u), float(np.abs(self.u[:, 2:]).max())) if explain else
                                (found.problems, "", math.nan))
        problems, forces, torque = self._facts[key]
        return list(problems), forces, torque


_REFERENCES: dict[tuple, object] = {}  # the reference's chunks, by what decides them
_MOST_REFERENCES = 16


def _reference(vehicle: str, scenario: dict, t: np.ndarray, lo: int, tick: float, hover, nominal: np.ndarray, ff) -> _Chunk:
    """The chunk of the reference at t (its samples, the nominal feedforward there, the trims' reference rows), computed
    once per trajectory and shape (not for a waypoint mission, whose file may change under its name): they depend on
    nothing else, and every point of a search over the plant's or the wind's parameters checks the same reference (read
    only)."""
    code = int(scenario.get("trajectory", 1))
    key = (vehicle, code, twin.shape_vector(scenario).tobytes(), lo, t.size, tick) if code != twin.WAYPOINTS else None
    if key is not None and key in _REFERENCES:
        return _REFERENCES[key]
    from .trim_residual import compiled_feedforward

    s, refs = _samples(vehicle, scenario, t)
    along = compiled_feedforward(vehicle)  # CasADi's map in C, the same bits (trim_residual.py)
    u = along(hover.x, refs, nominal) if along is not None else feedforward_map(ff, hover.x, refs, nominal)
    chunk = _Chunk(s, u, refs)
    if key is not None:
        _keep(key, chunk)
    return chunk


def feedforward_map(ff, hover_x: np.ndarray, refs: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The feedforward at each row of refs (the load's position, psi, their rates, its acceleration), the other
    coordinates at hover_x and at rest, with the parameters p: CasADi's map ((count, 4))."""
    nq = hover_x.size // 2
    x = np.tile(hover_x, (len(refs), 1))
    x[:, 0:3], x[:, 5], x[:, nq:] = refs[:, 0:3], refs[:, 3], 0.0
    x[:, nq:nq + 3], x[:, nq + 5] = refs[:, 4:7], refs[:, 7]
    qdd = np.zeros((len(refs), nq))
    qdd[:, 0:3] = refs[:, 8:11]
    return np.array(ff.map(len(refs))(x.T, qdd.T, np.repeat(p[:, None], len(refs), axis=1))).T


def _samples(vehicle: str, scenario: dict, t: np.ndarray) -> tuple[twin.Samples, np.ndarray]:
    """twin.evaluate(scenario, t), and its rows as the trims and the feedforward take them (the load's position, psi,
    their rates, its acceleration: 11 columns); a mission's by the scenario FMU's C where it is compiled (the same
    bits), the samples then views of its rows."""
    from .trim_residual import compiled_mission

    mission = compiled_mission(vehicle) if int(scenario.get("trajectory", 1)) == twin.WAYPOINTS else None
    if mission is None:
        s = twin.evaluate(scenario, t)
        return s, np.column_stack([s.p, s.psi, s.v, s.psi_dot, s.a])
    rows = mission(knot_file.from_parameters(scenario), t)
    return twin.Samples(t, rows[:, 0:3], rows[:, 4:7], rows[:, 8:11], rows[:, 3], rows[:, 7]), rows[:, :11]


def _keep(key: tuple, value) -> None:
    """Into _REFERENCES, the oldest entry dropped beyond _MOST_REFERENCES."""
    if len(_REFERENCES) >= _MOST_REFERENCES:
        _REFERENCES.pop(next(iter(_REFERENCES), None), None)
    _REFERENCES[key] = value


def _vector(vehicle: str, overrides: dict) -> np.ndarray:
    """The vehicle's parameter vector with the plant instance's overrides (m_L, ...; other names are not its)."""
    p = VEHICLES[vehicle].default_parameters()
    where = _parameter_index(vehicle)
    for name, value in overrides.items():
        if name in where:
            p[where[name]] = float(value)
    return p


@lru_cache(maxsize=4)
def _parameter_index(vehicle: str) -> dict[str, int]:
    return {s.name: k for k, s in enumerate(VEHICLES[vehicle].parameter_specs)}



def check_reference(scenario: dict, stop: float, vehicle: str = VEHICLE, plant: dict | None = None,
                    limits: Limits = Limits(), tick: float = 0.012, design: tuple[str, int] | None = None,
                    explain: bool = True) -> Report:
    """The feedforward and the trim along the reference of these scenario FMU parameters, over [0, stop] (at most
    MAX_SPAN: the reference is sampled CHUNK ticks at a time, so time and memory grow linearly with the span and
    stay bounded); with design = (dlqr or mixed, loop delay), the yaw that design holds. explain=False: the problems
    alone, the same ones (no summary, no notes: what a search's or a campaign's worker reads)."""
    from ....plant_fmu.trim import TrimError, unknown_coordinates
    from .trim_residual import compiled_newton, feedforward

    ff = feedforward(vehicle)
    unknown = unknown_coordinates(vehicle)
    names = VEHICLES[vehicle].coordinates
    nominal = VEHICLES[vehicle].default_parameters()
    actual = _vector(vehicle, plant or {})
    report = Report()
    try:
        hover = _hover(vehicle, nominal.tobytes())
        z = _trim_start(vehicle, actual.tobytes())
    except (TrimError, ValueError) as err:
        report.problems.append(f"the plant has no hover trim with these parameters ({err})")
        return report
    span = min(stop, MAX_SPAN)
    n = int(math.floor(span / tick + 1e-9)) + 1
    n_angles = len(unknown)
    u_ff = np.empty((n, 4)) if n > CHUNK else None  # (one chunk: its own array)
    previous = np.zeros(11)
    trims, times, failed = [], [], False  # arrays of trims (rows) and their times, a part a chunk
    jump, psi_worst, last = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), None
    for lo in range(0, n, CHUNK):
        t = np.arange(lo, min(lo + CHUNK, n)) * tick
        chunk = _reference(vehicle, scenario, t, lo, tick, hover, nominal, ff)
        s, refs = chunk.s, chunk.refs
        if u_ff is not None:
            u_ff[lo:lo + t.size] = chunk.u
        if lo == 0:  # hover at the start point (the first sample, t = 0): the trim there is the hover trim
            previous[0:3], previous[3] = s.p[0], s.psi[0]
        solver = compiled_newton(vehicle)
        if solver is not None and not failed:  # the loop below in C, the same bits (trim_residual.py)
            ks = np.arange((-lo) % TRIM_EVERY, t.size, TRIM_EVERY)
            found = solver.path(z, previous, refs[ks], actual, n_angles, 1e-9, 20)
            trims.append(found)
            times.append(t[ks[:len(found)]])
            if len(found):
                z, previous = found[-1], refs[ks[len(found) - 1]]
            if len(found) < len(ks):
                k = ks[len(found)]
                report.problems.append(f"no steady attitude carries the load's acceleration of {np.linalg.norm(s.a[k]):.3g} "
                                       f"m/s2 at t = {t[k]:.2f} s")
                failed = True
        for k in range((-lo) % TRIM_EVERY, t.size, TRIM_EVERY) if solver is None else ():
            if failed:
                break
            found = _trim(vehicle, z, previous, refs[k], actual, n_angles)
            if found is None:
                report.problems.append(f"no steady attitude carries the load's acceleration of {np.linalg.norm(s.a[k]):.3g} "
                                       f"m/s2 at t = {t[k]:.2f} s")
                failed = True
                break
            z, previous = found, refs[k]
            trims.append(z[None])
            times.append(t[k:k + 1])
        jump = max(jump, chunk.jump(last, tick)) if explain else jump
        psi_worst = max(psi_worst, chunk.psi_worst())
        last = (s.t[-1], s.p[-1], s.v[-1])
    t_all = np.arange(n) * tick
    if n <= CHUNK:  # one chunk: its own facts, once per reference
        problems, forces, torque = chunk.feedforward_facts(limits, explain)
        report.problems.extend(problems)
    else:
        _limit_inputs(report, "", u_ff, t_all, limits)
        forces, torque = _forces(u_ff), float(np.abs(u_ff[:, 2:]).max())
    trims, times = (parts[0] if len(parts) == 1 else np.concatenate(parts) if parts else np.empty(0) for parts in (trims, times))
    if len(trims):
        _limit_inputs(report, "the trim's ", trims[:, n_angles:], times, limits)
        angles = np.abs(np.degrees(trims[:, :n_angles]))
        worst = np.argmax(angles, axis=0)
        for j, i in enumerate(unknown):
            value, when = angles[worst[j], j], times[worst[j]]
            if value > limits.max_tilt:
                value = math.copysign(value, trims[worst[j], j])
                report.problems.append(f"{names[i]} would need {value:.1f} degrees at t = {when:.2f} s; the limit is "
                                       f"{limits.max_tilt:g} degrees (--max-tilt)")
        k_tilt = np.unravel_index(np.argmax(angles), angles.shape)
        tilt = angles[k_tilt]
    else:
        tilt, k_tilt = math.nan, (0, 0)
    yaw = yaw_problem(psi_worst[1:], design, vehicle)
    if yaw:
        report.problems.append(yaw)
    if not explain:
        return report
    if jump[0] > 0.01:
        report.notes.append(f"the reference jumps by {jump[1]:.3g} m at t = {jump[2]:.2f} s: no feedforward can "
                            "anticipate it, the feedback alone takes it")
    where = f" ({names[unknown[k_tilt[1]]]} at t = {times[k_tilt[0]]:.2f} s)" if len(times) else ""
    part = f" (the first {span:g} s of {stop:g} s)" if span < stop else ""
    report.summary = (f"feasibility over {t_all[-1]:.2f} s{part}: feedforward {forces}, |tau| <= {torque:.2f} N m (limits "
                      f"{limits.f_min:g}..{limits.f_max:g} N, {limits.tau_max:g} N m); trim tilt up to {tilt:.1f} degrees{where}, "
                      f"limit {limits.max_tilt:g}")
    return report


def _forces(u: np.ndarray) -> str:
    """The feedforward's thrusts' ranges, as the summary says them."""
    return ", ".join(f"{name} {u[:, i].min():.2f}..{u[:, i].max():.2f} N" for i, name in enumerate(INPUT_NAMES[:2]))


def _limit_inputs(report: Report, what: str, u: np.ndarray, t: np.ndarray, limits: Limits) -> None:
    """One line per input beyond its limit, at its worst sample (the first, when several are as bad)."""
    over = np.argmax(u[:, :2] - limits.f_max, axis=0).tolist()
    under = np.argmin(u[:, :2], axis=0).tolist()
    torque = np.argmax(np.abs(u[:, 2:]), axis=0).tolist()
    for i, name in enumerate(INPUT_NAMES):
        if i < 2:
            k_over, k_under = over[i], under[i]
            if u[k_over, i] - limits.f_max > 1e-9:
                report.problems.append(f"{what}{name} would need {u[k_over, i]:.3g} N at t = {t[k_over]:.2f} s; the limit is "
                                       f"{limits.f_max:g} N")
            if limits.f_min - u[k_under, i] > 1e-9:
                report.problems.append(f"{what}{name} would need {u[k_under, i]:.3g} N at t = {t[k_under]:.2f} s; the limit is "
                                       f"{limits.f_min:g} N")
        else:
            k = torque[i - 2]
            if abs(u[k, i]) > limits.tau_max + 1e-9:
                report.problems.append(f"{what}{name} would need {u[k, i]:.3g} N m at t = {t[k]:.2f} s; the limit is "
                                       f"+-{limits.tau_max:g} N m")


def _largest_jump(s, before, tick: float) -> tuple[float, float, float]:
    """(gap, step, time) of the largest jump in these samples (and from the chunk before's last sample): a position change
    over a tick beyond what the reference's own velocity covers (1.5 ticks of it). A reference that jumps (a step) has no
    feedforward for the jump: the feedback alone takes it."""
    p, v, t = s.p, s.v, s.t
    if before is not None:
        p, v, t = np.r_[before[1][None], p], np.r_[before[2][None], v], np.r_[before[0], t]
    step = np.linalg.norm(np.diff(p, axis=0), axis=1)
    speed = np.maximum(np.linalg.norm(v[:-1], axis=1), np.linalg.norm(v[1:], axis=1))
    gap = step - 1.5 * tick * speed
    if not gap.size:
        return (0.0, 0.0, 0.0)
    k = int(np.argmax(gap))
    return (float(gap[k]), float(step[k]), float(t[k + 1]))

