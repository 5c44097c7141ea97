"""The plant for a controller of your own: its parameters, hover trim and linear model (docs/design_api.md).

    import tiltload as tl

    p = tl.plant.parameters(m_L=0.2)                       # Table 5.1, one value changed
    eq = tl.plant.trim(p)                                   # the hover trim: eq.x, eq.u
    model = tl.plant.linearize(eq, dt=tl.plant.TICK)        # A, B, C, D, F at the trim, zero-order hold at 12 ms
"""

from __future__ import annotations

from .master.app.api.plant import TICK, ActuatorLimits, LinearModel, Parameters, Trim, limits, linearize, parameters, trim

__all__ = ["TICK", "ActuatorLimits", "LinearModel", "Parameters", "Trim", "limits", "linearize", "parameters", "trim"]
