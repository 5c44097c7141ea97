"""`tl.plant`: the plant's parameters, its hover trim and its linear model, for a user's own controller (docs/design_api.md).

A thin public face over the physics library (plant_fmu: parameters, trim, linearize) and the error dynamics the
thesis's designs are made on (controller_fmu/design/error_dynamics): the same numbers the shipped controllers use.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import numpy as np

from ....controller_fmu.design.error_dynamics import LOOP_DELAYS, ErrorDynamics, augmented_continuous, with_loop_delay
from ....plant_fmu import interface
from ....plant_fmu import parameters as table
from ....plant_fmu.linearize import linearize as _jacobians
from ....plant_fmu.linearize import zoh
from ....plant_fmu.trim import TrimError, hover_trim
from ....plant_fmu.vehicles import VEHICLES
from ..loop.defaults import VEHICLE
from ..loop.thesis import TICK
from .errors import TiltloadError

__all__ = ["TICK", "ActuatorLimits", "LinearModel", "Parameters", "Trim", "limits", "linearize", "parameters", "trim"]

# TICK (0.012 s) is the loop's sample time T_c (master/app/loop/thesis.py): every FMU of the loop steps on it, and a
# controller's period is a whole number of ticks (docs/ports.md)
_INTEGRALS = ("int_x", "int_y", "int_z", "int_psi")  # (3.8): the integrals of the x, y, z and psi errors


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _vehicle(vehicle: object) -> str:
    if not isinstance(vehicle, str):
        raise TypeError(f"vehicle must be a str, got {type(vehicle).__name__}")
    if vehicle not in VEHICLES:
        raise TiltloadError(f"unknown vehicle {vehicle!r} (available: {', '.join(VEHICLES)})")
    return vehicle


def _real(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    if not math.isfinite(value):
        raise TiltloadError(f"{name} must be finite, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class ActuatorLimits:
    """Table 5.2: each thrust in [f_min, f_max] N, each servo torque in [-tau_max, tau_max] N m (the plant saturates)."""

    f_min: float
    f_max: float
    tau_max: float

    def clip(self, u) -> np.ndarray:
        """u = [f_R, f_L, tau_R, tau_L] saturated as the plant saturates it."""
        u = np.asarray(u, dtype=float)  # numpy's functions only, so a traced step (wrap --native) saturates with it too
        return np.concatenate([np.clip(u[:2], self.f_min, self.f_max), np.clip(u[2:4], -self.tau_max, self.tau_max)])


def limits() -> ActuatorLimits:
    """The actuator limits of Table 5.2 (the plant FMU's defaults)."""
    return ActuatorLimits(**{s.name: s.default for s in table.ACTUATOR_LIMITS})


@dataclass(frozen=True, eq=False)
class Parameters(Mapping[str, float]):
    """A vehicle's physical parameters (Table 5.1), read-only: ``p["m_L"]``, ``p.unit("m_L")``, ``p.replace(m_L=0.2)``.

    The names are the plant FMU's parameters (docs/plant.md); ``vector`` is their values in the model's order."""

    vehicle: str
    vector: np.ndarray

    def __getitem__(self, name: str) -> float:
        return float(self.vector[self._index(name)])

    def __iter__(self) -> Iterator[str]:
        return iter(VEHICLES[self.vehicle].parameters)

    def __len__(self) -> int:
        return len(VEHICLES[self.vehicle].parameters)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Parameters) and other.vehicle == self.vehicle and np.array_equal(other.vector, self.vector)

    def __hash__(self) -> int:
        return hash((self.vehicle, self.vector.tobytes()))

    def __repr__(self) -> str:
        changed = {k: v for k, v in self.items() if v != _DEFAULTS[k]}
        return f"Parameters(vehicle={self.vehicle!r}, Table 5.1{''.join(f', {k}={v:g}' for k, v in changed.items())})"

    def _index(self, name: str) -> int:
        if not isinstance(name, str):
            raise TypeError(f"a parameter name must be a str, got {type(name).__name__}")
        try:
            return VEHICLES[self.vehicle].parameters.index(name)
        except ValueError:
            raise KeyError(f"the {self.vehicle} vehicle has no parameter {name!r}") from None

    def unit(self, name: str) -> str:
        return _SPECS[self.vehicle][self._index(name)].unit

    def description(self, name: str) -> str:
        return _SPECS[self.vehicle][self._index(name)].description

    def replace(self, **overrides: float) -> Parameters:
        """A copy with some values replaced by name, checked as a physical plant (TiltloadError if not)."""
        vector = np.array(self.vector)
        for name, value in overrides.items():
            if name not in self:
                raise TiltloadError(f"the {self.vehicle} vehicle has no parameter {name!r} (see tl.plant.parameters())")
            vector[self._index(name)] = _real(name, value)
        full = np.array(VEHICLES[self.vehicle].full_parameters(vector), dtype=float).ravel()
        try:
            table.validate(full)
        except table.ParameterError as err:
            raise TiltloadError(str(err)) from None
        return Parameters(self.vehicle, _frozen(vector))


_SPECS = {name: v.parameter_specs for name, v in VEHICLES.items()}
_DEFAULTS = {s.name: s.default for s in table.MODEL_PARAMETERS}


def parameters(vehicle: str = VEHICLE, **overrides: float) -> Parameters:
    """The vehicle's parameters ("load": the UAV with its suspended load, ch. 2; "uav": the UAV alone, Appendix A),
    Table 5.1 with the given overrides: ``tl.plant.parameters(m_L=0.2)``."""
    vehicle = _vehicle(vehicle)
    base = Parameters(vehicle, _frozen(VEHICLES[vehicle].default_parameters()))
    return base.replace(**overrides) if overrides else base


def _names(vehicle: str) -> tuple[str, ...]:
    return interface.STATE_NAMES if vehicle == "load" else interface.UAV_STATE_NAMES


@dataclass(frozen=True, eq=False)
class Trim:
    """A hover equilibrium: state x (named by ``state_names``), inputs u = [f_R, f_L, tau_R, tau_L], the parameters it
    was solved with, and the force residual max|L_in u - g(q)| (N or N m) Newton's method stopped at."""

    x: np.ndarray
    u: np.ndarray
    parameters: Parameters
    residual: float
    state_names: tuple[str, ...]
    input_names: tuple[str, ...] = interface.INPUT_NAMES

    @property
    def vehicle(self) -> str:
        return self.parameters.vehicle

    def state(self, name: str) -> float:
        """One entry of x by its name: ``trim.state("gamma_2")``."""
        return float(self.x[self.state_names.index(name)])


def trim(params: Parameters | None = None, *, psi: float = 0.0, position=(0.0, 0.0, 0.0), vehicle: str = VEHICLE) -> Trim:
    """The hover trim (q_dot = 0, the model's derivative zero) at yaw psi (rad) and the load's (or the UAV's) position.

    params: a ``tl.plant.parameters(...)`` (default: Table 5.1 of the vehicle)."""
    if params is None:
        params = parameters(vehicle)
    elif not isinstance(params, Parameters):
        raise TypeError(f"params must be a tl.plant.Parameters (tl.plant.parameters()), got {type(params).__name__}")
    psi = _real("psi", psi)
    try:
        position = tuple(_real("position", v) for v in position)
    except TypeError:
        raise TypeError(f"position must be three numbers (x, y, z), got {position!r}") from None
    if len(position) != 3:
        raise TiltloadError(f"position must be three numbers (x, y, z), got {len(position)}")
    try:
        found = hover_trim(params.vector, psi=psi, position=position, vehicle=params.vehicle)
    except (TrimError, table.ParameterError) as err:
        raise TiltloadError(str(err)) from None
    return Trim(_frozen(found.x), _frozen(found.u), params, found.residual, _names(params.vehicle))


@dataclass(frozen=True, eq=False)
class LinearModel:
    """The plant linearized at a trim: x' = A x + B u + F d (continuous, ``dt`` None) or x[k+1] = A x[k] + B u[k] + F d[k]
    (zero-order hold at ``dt``), y = C x + D u, in deviations from the trim. y is the plant's state (the exact-state
    channel the sensor suite gives: ``exact_<state>``). ``state_names`` names every state: the plant's 20 (16 for the
    UAV alone), then the integrals of the x, y, z, psi errors (``integral``), then the delayed inputs (``delay_ticks``),
    the oldest first."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    F: np.ndarray  # the disturbance force on the load's centre, d = [d_x, d_y, d_z] (N)
    dt: float | None
    delay_ticks: int
    integral: bool
    trim: Trim
    state_names: tuple[str, ...]
    input_names: tuple[str, ...] = interface.INPUT_NAMES
    disturbance_names: tuple[str, ...] = interface.DISTURBANCE_NAMES

    def poles(self) -> np.ndarray:
        """The eigenvalues of A (open loop)."""
        return np.linalg.eigvals(self.A)


def _int_ticks(delay_ticks: object) -> int:
    if isinstance(delay_ticks, bool) or not isinstance(delay_ticks, int | np.integer):
        raise TypeError(f"delay_ticks must be an int, got {type(delay_ticks).__name__}")
    if delay_ticks not in LOOP_DELAYS:
        raise TiltloadError(f"delay_ticks must be one of {', '.join(map(str, LOOP_DELAYS))} (the loop's delays), got {delay_ticks}")
    return int(delay_ticks)


def linearize(at: Trim | None = None, *, dt: float | None = None, delay_ticks: int = 0, integral: bool = False) -> LinearModel:
    """The linear model at a trim (default: the hover trim of Table 5.1), by CasADi's exact Jacobians.

    dt: None for the continuous model; a sample time (s) for its exact zero-order-hold discretization, usually
    ``tl.plant.TICK``, the loop's 12 ms. delay_ticks (discrete only): the inputs reach the plant that many ticks after
    they are computed (the loop's ``--delay``), modelled as 4 more states per tick. integral: append the integrals of
    the x, y, z, psi errors (thesis 3.8), the state chi the thesis's designs feed back."""
    if at is None:
        at = trim()
    elif not isinstance(at, Trim):
        raise TypeError(f"at must be a tl.plant.Trim (tl.plant.trim()), got {type(at).__name__}")
    if dt is not None:
        dt = _real("dt", dt)
        if dt <= 0:
            raise TiltloadError(f"dt must be positive, got {dt:g}")
    delay_ticks = _int_ticks(delay_ticks)
    if delay_ticks and dt is None:
        raise TiltloadError("delay_ticks needs a discrete model: give dt (e.g. dt=tl.plant.TICK)")
    if not isinstance(integral, bool):
        raise TypeError(f"integral must be a bool, got {type(integral).__name__}")
    vehicle = at.vehicle
    lin = _jacobians(at.x, at.u, at.parameters.vector, vehicle=vehicle)
    A, B, F = augmented_continuous(lin.A, lin.B, lin.F) if integral else (lin.A, lin.B, lin.F)
    if dt is not None:  # B and F in one hold, as the thesis's error dynamics are discretized
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused below, in one line
            A, BF = zoh(A, np.hstack([B, F]), dt)
        if not (np.isfinite(A).all() and np.isfinite(BF).all()):
            raise TiltloadError(f"dt = {dt:g} s: the discrete model overflows (the hovering plant is unstable: over this "
                                "step its modes grow past a double's range); a sample time of seconds at most (the "
                                "loop's is tl.plant.TICK, 12 ms)")
        B, F = BF[:, :4], BF[:, 4:]
        if delay_ticks:
            delayed = with_loop_delay(ErrorDynamics(A, B, F, dt, at, at.parameters.vector), delay_ticks)
            A, B, F = delayed.A, delayed.B, delayed.F
    names = _names(vehicle) + (_INTEGRALS if integral else ())
    names += tuple(f"{u}[k-{delay_ticks - j}]" for j in range(delay_ticks) for u in interface.INPUT_NAMES)
    nx = at.x.size
    C = np.zeros((nx, A.shape[0]))
    C[:, :nx] = np.eye(nx)
    return LinearModel(_frozen(A), _frozen(B), _frozen(C), _frozen(np.zeros((nx, 4))), _frozen(F), dt, delay_ticks, integral,
                       at, names)
