"""Time-stamped waypoints turned into a minimum-jerk reference: piecewise quintics with continuous position,
velocity and acceleration (the feedforward (3.18) reads the acceleration).

Why minimum jerk (and quintics): the controller's feedforward uses the load's position, velocity and
acceleration only (control_law.StateFeedback: the other coordinates at their trim), so the reference needs
continuous acceleration and no more. The quintic is the lowest degree that can meet a position, a velocity
and an acceleration at both ends of a segment, so the user's velocity and acceleration constraints are honoured
exactly; among the C2 piecewise quintics through the waypoints, the one of least integral squared jerk has, at
every waypoint left free, continuous jerk and snap as well (its optimality conditions). Minimum snap would need
degree 7, overshoots more between waypoints and buys derivatives the loop does not use.

The optimum is closed form: the cost is a quadratic in the free velocities and accelerations at the waypoints
(each segment's is dᵀHd/T⁵ in its scaled Hermite data d), so one symmetric positive definite linear solve gives
them; no iterative solver. The result is carried into the scenario FMU as data (a knot file its waypoints_file parameter names: time,
position, velocity and acceleration at each waypoint, for x, y, z and psi) and evaluated there in C, segment
by segment as a quintic Hermite polynomial (scenario_waypoints.c); evaluate() below is the same arithmetic in numpy.

Boundary conditions: a velocity or acceleration left out at the first or last waypoint is 0 (the path starts
and ends at rest); left out at an interior waypoint it is free. Before the first time and after the last the
reference holds the end waypoint at rest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .files import ScenarioFileError

AXES = ("x", "y", "z", "psi")
FIELDS = ("t", *AXES, *(f"v{a}" for a in AXES), *(f"a{a}" for a in AXES))  # a waypoint's columns
REQUIRED = ("t", "x", "y", "z")
UNITS = {"t": "s", "x": "m", "y": "m", "z": "m", "psi": "rad"}
UNITS |= {f"v{a}": f"{UNITS[a]}/s" for a in AXES} | {f"a{a}": f"{UNITS[a]}/s2" for a in AXES}
MAX_WAYPOINTS = 10_000  # the scenario FMU's capacity: its state holds the knots (13 doubles each, 1 MB in all)
# The knot file that carries a reference into the scenario FMU (its waypoints_file parameter): a header naming these
# columns, then one line per knot, numbers in %.17g (exact both ways).
KNOT_COLUMNS = ("t", *(f"{q}{a}" for a in AXES for q in ("", "v", "a")))
KNOT_LINE = 512  # characters in a knot line at most (13 numbers of at most 24 characters and their commas: 324)
PATH_LENGTH = 1023  # characters in waypoints_file at most (the FMU keeps it in its state)
# Time spans are bounded by what a run can be: a mission ends within MAX_TIME (3 h, beyond the endurance of a battery
# multirotor carrying a load; 900,000 ticks of 12 ms, the schedule's and the feasibility check's samples), and
# consecutive waypoints are MIN_GAP apart at least (the jerk cost scales as T^-5: at 1 ms it is 1e15, which the
# equilibrated solve takes; at 1e-300 s it overflows, and a 12 ms tick cannot see a finer waypoint anyway).
MAX_TIME = 10_800.0  # s
MIN_GAP = 1e-3  # s
# Values bounded so that every product the quintics form stays far from overflow (T^2 a with T <= MAX_TIME).
RANGES = {"t": (0.0, MAX_TIME), "x": (-1e5, 1e5), "y": (-1e5, 1e5), "z": (-1e5, 1e5), "psi": (-1e3, 1e3)}
RANGES |= {f"v{a}": (-1e3, 1e3) for a in AXES} | {f"a{a}": (-1e4, 1e4) for a in AXES}

SCHEMA = {  # one waypoint (a CSV row, or an item of a JSON/YAML file's `waypoints`)
    "type": "object", "required": list(REQUIRED), "additionalProperties": False,
    "properties": {f: {"type": "number", "minimum": RANGES[f][0], "maximum": RANGES[f][1]} for f in FIELDS},
}


FIELD_SET, REQUIRED_SET = frozenset(FIELDS), frozenset(REQUIRED)


def _number(value) -> bool:
    """A JSON Schema number: an int or a float, not a bool."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def check(rows: list[dict], where: list[str], source: str) -> None:
    """The waypoints' shape and values, the first problem as one line: `source: where: problem`.

    rows are mappings of FIELDS to numbers; where[i] names row i for the user ("line 4", "waypoints.3")."""
    import jsonschema

    if len(rows) < 2:
        raise ScenarioFileError(f"{source}: a trajectory needs at least 2 waypoints, got {len(rows)}")
    if not all(isinstance(r, dict) for r in rows):
        raise ScenarioFileError(f"{source}: a waypoint is a mapping of t, x, y, z[, psi, vx, ...]")
    if len(rows) > MAX_WAYPOINTS:
        raise ScenarioFileError(f"{source}: at most {MAX_WAYPOINTS} waypoints fit the scenario FMU, got {len(rows)}")
    for row, at in zip(rows, where):
        for field, value in row.items():  # before the schema: its message would print a 400-digit number whole
            if isinstance(value, (int, float)) and not isinstance(value, bool) and not math.isfinite(value):
                raise ScenarioFileError(f"{source}: {at}: {field} is {value}, not a finite number")
            if field == "t" and isinstance(value, (int, float)) and value < 0:
                raise ScenarioFileError(f"{source}: {at}: t = {value:g} s is before the run starts (t = 0)")
            if field in RANGES and isinstance(value, (int, float)) and not RANGES[field][0] <= value <= RANGES[field][1]:
                low, high = RANGES[field]
                raise ScenarioFileError(f"{source}: {at}: {field} = {float(value):.6g} is outside {low:g} to {high:g} "
                                        f"{UNITS[field]}" + (" (a mission ends within 3 h)" if field == "t" else ""))
    # rows of known fields, the required ones among them, every value a number (their ranges checked above) meet the
    # schema: it is asked only otherwise, for its line (a search's moved missions are checked a millisecond faster)
    plain = all(set(r) <= FIELD_SET and REQUIRED_SET <= set(r) and all(_number(v) for v in r.values()) for r in rows)
    err = None
    if not plain:
        validator = jsonschema.Draft202012Validator({"type": "array", "items": SCHEMA})
        err = next(iter(sorted(validator.iter_errors(rows), key=lambda e: list(e.path))), None)
    if err is not None:
        at, field = where[err.absolute_path[0]], ".".join(str(p) for p in list(err.absolute_path)[1:])
        if err.validator == "additionalProperties":
            extra = sorted(set(rows[err.absolute_path[0]]) - set(FIELDS))
            raise ScenarioFileError(f"{source}: {at}: unknown field {', '.join(e[:40] for e in extra[:3])} "
                                    f"(a waypoint has {', '.join(FIELDS)})")
        raise ScenarioFileError(f"{source}: {at}{': ' + field if field else ''}: {err.message[:200]}")
    if len({("psi" in r) for r in rows}) > 1:
        raise ScenarioFileError(f"{source}: psi is given at some waypoints but not all")
    if any(("vpsi" in r or "apsi" in r) and "psi" not in r for r in rows):
        raise ScenarioFileError(f"{source}: a psi rate or acceleration without psi")
    if rows[0]["t"] < 0:
        raise ScenarioFileError(f"{source}: {where[0]}: t = {rows[0]['t']:g} s is before the run starts (t = 0)")
    for k in range(1, len(rows)):
        if not rows[k]["t"] > rows[k - 1]["t"]:
            raise ScenarioFileError(f"{source}: {where[k]}: t = {rows[k]['t']:g} s is not after the previous waypoint's "
                                    f"t = {rows[k - 1]['t']:g} s (times must increase)")
        if rows[k]["t"] - rows[k - 1]["t"] < MIN_GAP:
            raise ScenarioFileError(f"{source}: {where[k]}: t = {rows[k]['t']:.17g} s is {rows[k]['t'] - rows[k - 1]['t']:.3g} s "
                                    f"after the previous waypoint; waypoints are at least {MIN_GAP:g} s apart")


def _hermite_to_monomial() -> np.ndarray:
    """B: monomial coefficients of P(s) on [0, 1] from d = [p0, T v0, T^2 a0, p1, T v1, T^2 a1]."""
    return np.array([
        [1, 0, 0, 0, 0, 0],
        [0, 1, 0, 0, 0, 0],
        [0, 0, 0.5, 0, 0, 0],
        [-10, -6, -1.5, 10, -4, 0.5],
        [15, 8, 1.5, -15, 7, -1],
        [-6, -3, -0.5, 6, -3, 0.5],
    ])


def _jerk_gram() -> np.ndarray:
    """H with integral_0^1 P'''(s)^2 ds = d' H d."""
    B = _hermite_to_monomial()
    a = np.array([6.0, 24.0, 60.0])  # P''' = 6 c3 + 24 c4 s + 60 c5 s^2
    M = np.array([[a[j] * a[k] / (j + k + 1) for k in range(3)] for j in range(3)])
    return B[3:].T @ M @ B[3:]


B_HERMITE = _hermite_to_monomial()
H_JERK = _jerk_gram()


def _segments(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The jerk cost's matrix as its segments' blocks (each S H S / T^5) in w = [p0, v0, a0, p1, ...]: the entries, their
    rows and their columns (the same for every axis of a mission)."""
    T = np.diff(t)
    S = np.empty((T.size, 6))  # (n-1, 6): [1, T, T^2] twice
    S[:, 0] = S[:, 3] = 1.0
    S[:, 1] = S[:, 4] = T
    S[:, 2] = S[:, 5] = T * T
    blocks = S[:, :, None] * H_JERK[None] * S[:, None, :] / (T**5)[:, None, None]
    rows, cols = _block_indices(T.size)
    return blocks.ravel(), rows, cols


@lru_cache(maxsize=16)
def _block_indices(segments: int) -> tuple[np.ndarray, np.ndarray]:
    """The global row and column of each entry of the segments' 6 x 6 blocks, in _segments' order (read-only: shared
    by every mission of as many knots)."""
    rows = (3 * np.arange(segments))[:, None, None] + np.arange(6)[None, :, None]
    cols = (3 * np.arange(segments))[:, None, None] + np.arange(6)[None, None, :]
    shape = (segments, 6, 6)
    rows, cols = np.broadcast_to(rows, shape).ravel(), np.broadcast_to(cols, shape).ravel()
    rows.flags.writeable = cols.flags.writeable = False
    return rows, cols


def _free_system(free: np.ndarray, segments) -> tuple:
    """What the free entries decide (the same for every axis that leaves the same ones free): their positions, the
    entries that couple them to the known ones, and the equilibrated upper band of their block."""
    values, rows, cols = segments
    position, into, both, on, i_on, upper, iu, ju, band, flat, size = _free_pattern(free.tobytes(), rows.size // 36)
    g = values[both]
    diagonal = np.bincount(i_on, g[on], minlength=size)  # (bincount sums in the order given, as np.add.at does: the
    scale = 1 / np.sqrt(diagonal)  # same bits, a fifth of the time) the entries span powers of the segment times
    ab = np.bincount(flat, g[upper] * scale[iu] * scale[ju], minlength=(band + 1) * size)
    return position, into, scale, ab.reshape(band + 1, size)  # the upper band, as scipy.linalg.solveh_banded takes it


@lru_cache(maxsize=64)
def _free_pattern(free: bytes, segments: int) -> tuple:
    """_free_system's indices, which depend on which entries are free and the number of segments alone (not on the
    times): kept per pattern, read-only (a search that moves a waypoint's time or position meets the same ones)."""
    free = np.frombuffer(free, dtype=bool)
    rows, cols = _block_indices(segments)
    position = np.cumsum(free) - 1  # index among the free entries
    known = ~free
    into = free[rows] & known[cols]  # b = -G[free, known] w[known]
    both = free[rows] & free[cols]
    i, j = position[rows[both]], position[cols[both]]
    size = int(free.sum())
    on, upper = i == j, i <= j
    iu, ju = i[upper], j[upper]
    band = int((ju - iu).max())
    out = (position, into, both, on, i[on], upper, iu, ju, band, (band + iu - ju) * size + ju, size)
    for array in out:
        if isinstance(array, np.ndarray):
            array.flags.writeable = False
    return out


def _solve_banded(ab: np.ndarray, b: np.ndarray) -> np.ndarray:
    """scipy.linalg.solveh_banded(ab, b) (the upper form) by the LAPACK routine it calls, without its checks of
    arrays made finite here (40 us of a moved mission's 0.2 ms solve): the same routine on the same arrays, the same
    bits."""
    from scipy.linalg import LinAlgError
    from scipy.linalg.lapack import dpbsv, dptsv

    if ab.shape[0] == 2:  # tridiagonal: solveh_banded's own choice
        _, _, x, info = dptsv(ab[1], ab[0, 1:], b)
    else:
        _, x, info = dpbsv(ab, b, lower=0)
    if info != 0:
        raise LinAlgError(f"the minimum-jerk system is singular (LAPACK info {info})")
    return x


def _solve_axes(t: np.ndarray, p: np.ndarray, v: list, a: list, segments=None) -> tuple[np.ndarray, np.ndarray]:
    """Minimum-jerk velocities and accelerations at the knots of each axis (p (n, k); v, a: each axis's list, None
    entries free). segments: _segments(t). The axes that leave the same entries free share one solve (each its own
    right-hand side: the same arithmetic as a solve of its own).

    The cost couples only the two ends of a segment, so its matrix is banded (half-bandwidth 5 in w = [p0, v0, a0,
    p1, ...]; at most 3 among the free entries): a banded Cholesky solve, linear in the number of knots."""
    n, k = p.shape
    w = np.full((3 * n, k), np.nan)
    w[0::3] = p
    for axis in range(k):
        for i in range(n):
            if v[axis][i] is not None:
                w[3 * i + 1, axis] = v[axis][i]
            if a[axis][i] is not None:
                w[3 * i + 2, axis] = a[axis][i]
    free = np.isnan(w)
    groups: dict[bytes, list[int]] = {}
    for axis in range(k):
        if free[:, axis].any():
            groups.setdefault(free[:, axis].tobytes(), []).append(axis)
    if groups:
        segments = segments if segments is not None else _segments(t)
        values, rows, cols = segments
    for axes in groups.values():
        mask = free[:, axes[0]]
        position, into, scale, ab = _free_system(mask, segments)
        b = np.empty((scale.size, len(axes)))
        target, coupling, known = position[rows[into]], -values[into], cols[into]
        for c, axis in enumerate(axes):
            b[:, c] = np.bincount(target, coupling * w[known, axis], minlength=scale.size)
        solved = _solve_banded(ab, b * scale[:, None])
        for c, axis in enumerate(axes):
            w[mask, axis] = scale * solved[:, c]
    return w[1::3].copy(), w[2::3].copy()


@dataclass(frozen=True)
class MinimumJerk:
    """The reference: at each knot its time and the position, velocity, acceleration of x, y, z, psi ((n, 4) each)."""

    t: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    @property
    def start(self) -> tuple[float, float, float]:
        return tuple(float(x) for x in self.p[0, :3])

    def evaluate(self, times) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration ((len(times), 4)) at the times; the end waypoints held at rest outside.
        The arithmetic of scenario_waypoints.c, operation for operation (the two agree to the last bit)."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        n = self.t.size
        lo = np.clip(np.searchsorted(self.t, times, side="right") - 1, 0, n - 2)
        hi = lo + 1
        T = (self.t[hi] - self.t[lo])[:, None]
        s = (times[:, None] - self.t[lo][:, None]) / T
        dp = self.p[hi] - self.p[lo]
        m0, m1, a0, a1 = T * self.v[lo], T * self.v[hi], T * T * self.a[lo], T * T * self.a[hi]
        c0, c1, c2 = self.p[lo], m0, 0.5 * a0
        c3 = 10.0 * dp - 6.0 * m0 - 4.0 * m1 - 1.5 * a0 + 0.5 * a1
        c4 = -15.0 * dp + 8.0 * m0 + 7.0 * m1 + 1.5 * a0 - a1
        c5 = 6.0 * dp - 3.0 * m0 - 3.0 * m1 - 0.5 * a0 + 0.5 * a1
        pos = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
        vel = (c1 + s * (2.0 * c2 + s * (3.0 * c3 + s * (4.0 * c4 + s * 5.0 * c5)))) / T
        acc = (2.0 * c2 + s * (6.0 * c3 + s * (12.0 * c4 + s * 20.0 * c5))) / (T * T)
        before, after = times < self.t[0], times >= self.t[-1]
        pos[before], pos[after] = self.p[0], self.p[-1]
        vel[before | after] = 0.0
        acc[before | after] = 0.0
        return pos, vel, acc

    def knots(self) -> np.ndarray:
        """The knot table, (n, 13) in the order of KNOT_COLUMNS."""
        out = np.empty((self.t.size, len(KNOT_COLUMNS)))
        out[:, 0] = self.t
        for k in range(len(AXES)):
            out[:, 1 + 3 * k], out[:, 2 + 3 * k], out[:, 3 + 3 * k] = self.p[:, k], self.v[:, k], self.a[:, k]
        return out

    @classmethod
    def from_knots(cls, knots: np.ndarray) -> MinimumJerk:
        knots = np.asarray(knots, dtype=float)  # each axis's position, velocity, acceleration: every third column
        return cls(knots[:, 0].copy(), *(np.ascontiguousarray(knots[:, 1 + q::3]) for q in range(3)))


def minimum_jerk(rows: list[dict]) -> MinimumJerk:
    """The minimum-jerk reference through checked waypoints (check())."""
    t = np.array([r["t"] for r in rows], dtype=float)
    n = t.size
    p = np.array([[r.get(axis, 0.0) for axis in AXES] for r in rows], dtype=float).reshape(n, len(AXES))
    ends = (0, n - 1)
    v = [[r.get(f"v{axis}", 0.0 if i in ends else None) for i, r in enumerate(rows)] for axis in AXES]
    a = [[r.get(f"a{axis}", 0.0 if i in ends else None) for i, r in enumerate(rows)] for axis in AXES]
    if n > 1:
        v_knots, a_knots = _solve_axes(t, p, v, a)
    else:
        v_knots, a_knots = np.array(v, dtype=float).T, np.array(a, dtype=float).T
    return MinimumJerk(t, p, v_knots, a_knots)
