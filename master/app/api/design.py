"""`tl.design`: the thesis's state-feedback designs for a user's own controller (docs/design_api.md).

A thin public face over controller_fmu/design: the discrete LQR (Sec. 3.3) on any discrete model from
``tl.plant.linearize``, and the pure H-infinity and mixed H2/H-infinity designs with the LMI pole regions (Sec. 3.4)
that the shipped controller FMU embeds, taken from the designs shipped with tiltload or the design cache.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from ....controller_fmu.design.dlqr import design_dlqr
from ....controller_fmu.design.error_dynamics import DesignError, ErrorDynamics
from ....controller_fmu.design.lmi_check import EPS_REGION, VARPI_REGION
from ....controller_fmu.design.synthesize import design as thesis_design
from ....controller_fmu.design.weights import delayed, omega_chi, omega_u
from .errors import TiltloadError
from .plant import TICK, LinearModel, linearize, trim

__all__ = ["REGIONS", "Design", "dlqr", "hinf", "mixed", "weights"]

REGIONS = (EPS_REGION, VARPI_REGION)  # the LMI pole regions of Sec. 5.2: Re(z) > 0.55 and |z| < 0.99402


@dataclass(frozen=True, eq=False)
class Design:
    """A state-feedback gain and what it was made on: u = u_trim - K chi, chi the model's state (``model.state_names``).

    poles: the closed loop's, eig(A - B K) of ``model``. Q, R: the weights used (Omega_chi, Omega_u). regions (LMI
    designs): (eps, varpi), every pole has Re(z) > eps and |z| < varpi. gamma: the H-infinity bound from d to the
    weighted error (prescribed for the mixed design, minimized for the pure one); h2_bound: the mixed design's H2
    bound. origin: "computed" (here, now), "shipped" (with tiltload, checked on this model), "cache" or "synthesized"."""

    kind: str
    K: np.ndarray
    poles: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    model: LinearModel
    origin: str
    regions: tuple[float, float] | None = None
    gamma: float | None = None
    h2_bound: float | None = None

    @property
    def spectral_radius(self) -> float:
        return float(np.abs(self.poles).max())


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def weights(model: LinearModel | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The thesis's weights (Omega_chi, Omega_u) of Sec. 5.2 (docs/controller.md) for a model with the integral states
    (``tl.plant.linearize(..., integral=True)``), a small weight on each delayed input; new arrays, yours to change."""
    model = _discrete(model)
    if not model.integral:
        raise TiltloadError("the thesis's weights are for the model with the integral states: linearize(..., integral=True)")
    R = omega_u(model.trim.u)
    return delayed(omega_chi(model.trim.vehicle), R, model.delay_ticks), R


def _discrete(model: object) -> LinearModel:
    if model is None:
        return linearize(dt=TICK, integral=True)
    if not isinstance(model, LinearModel):
        raise TypeError(f"model must be a tl.plant.LinearModel (tl.plant.linearize()), got {type(model).__name__}")
    if model.dt is None:
        raise TiltloadError("the designs are discrete: linearize with a sample time (dt=tl.plant.TICK)")
    return model


def _matrix(name: str, value: object) -> np.ndarray:
    try:
        return np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a matrix of numbers, got {type(value).__name__}") from None


@contextmanager
def _numerically(kind: str, dt: float):
    """A design's own refusal, or its numerics failing on a model of a huge sample time (an SVD that does not converge
    on matrices near a double's range), as one TiltloadError; numpy's overflow warnings on the way are not the user's
    to read (the outcome is checked: K finite)."""
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            yield
    except DesignError as err:
        raise TiltloadError(str(err)) from None
    except (np.linalg.LinAlgError, FloatingPointError) as err:
        raise TiltloadError(f"the {kind} design at dt = {dt:g} s failed numerically ({err}): the model of so long a "
                            "sample time is beyond what the design can solve (the loop's is tl.plant.TICK, 12 ms)") from None


def _finite_gain(kind: str, dt: float, K) -> np.ndarray:
    if not np.isfinite(K).all():
        raise TiltloadError(f"the {kind} design at dt = {dt:g} s gave a gain that is not finite: the model of so long a "
                            "sample time is beyond what the design can solve (the loop's is tl.plant.TICK, 12 ms)")
    return _frozen(K)


def dlqr(model: LinearModel | None = None, Q=None, R=None) -> Design:
    """The discrete LQR gain: K minimizing sum(chi' Q chi + du' R du) on a discrete model, from the discrete Riccati
    equation (scipy). Defaults: the thesis's DLQR, the model with the integral states at the loop's tick and its
    weights (``weights``)."""
    model = _discrete(model)
    if Q is None or R is None:
        default_Q, default_R = weights(model)
        Q = default_Q if Q is None else Q
        R = default_R if R is None else R
    Q, R = _matrix("Q", Q), _matrix("R", R)
    with _numerically("dlqr", model.dt):
        found = design_dlqr(ErrorDynamics(model.A, model.B, model.F, model.dt, model.trim, model.trim.parameters.vector), Q, R)
    K = _finite_gain("dlqr", model.dt, found.K)
    return Design("dlqr", K, np.linalg.eigvals(model.A - model.B @ K), _frozen(Q), _frozen(R), model, "computed")


def _lmi(kind: str, dt: float, delay_ticks: int, progress: Callable[[str], None] | None) -> Design:
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a function of one str, got {type(progress).__name__}")
    model = linearize(trim(), dt=dt, delay_ticks=delay_ticks, integral=True)  # checks dt and delay_ticks
    with _numerically(kind, model.dt):
        found = thesis_design(kind, model.dt, use_cache=True, loop_delay=delay_ticks, progress=progress)
    report: Mapping = found.report
    K = _finite_gain(kind, model.dt, found.K)
    return Design(kind, K, np.linalg.eigvals(model.A - model.B @ K), _frozen(found.omega_chi), _frozen(found.omega_u), model,
                  found.origin, REGIONS, report.get("gamma_bound"), report.get("h2_bound"))


def mixed(*, dt: float = TICK, delay_ticks: int = 0, progress: Callable[[str], None] | None = None) -> Design:
    """The thesis's mixed H2/H-infinity design with the LMI pole regions (Sec. 3.4.4, 5.2): minimum H2 bound with the
    H-infinity bound prescribed, gamma = 24, for the UAV with its load at Table 5.1, on the model with the integral
    states (and delay_ticks of input delay). The designs for dt = TICK and delays 0, 1, 2 come with tiltload (checked
    on this model in milliseconds); any other is synthesized (minutes: SDPA) and cached. progress hears what happens."""
    return _lmi("mixed", dt, delay_ticks, progress)


def hinf(*, dt: float = TICK, delay_ticks: int = 0, progress: Callable[[str], None] | None = None) -> Design:
    """The thesis's pure H-infinity design with the LMI pole regions (Sec. 3.4): the minimum H-infinity bound gamma from
    the disturbance to the weighted error, as ``mixed`` otherwise (shipped for dt = TICK without delay)."""
    return _lmi("hinf", dt, delay_ticks, progress)
