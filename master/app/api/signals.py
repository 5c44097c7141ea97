"""`tl.saturate`, `tl.choose`, `tl.dead_zone`, `tl.rate_limit`: a controller's usual nonlinearities in numpy alone, so a
class written with them runs as Python and traces into C (`tiltload wrap --native`) without importing CasADi: each is
numpy's functions, which a traced array answers symbolically (docs/ports.md, "A native FMU from Python")."""

from __future__ import annotations

import numpy as np

__all__ = ["choose", "dead_zone", "rate_limit", "saturate"]


def saturate(x, low, high):
    """x limited to [low, high], elementwise (np.clip)."""
    return np.clip(x, low, high)


def choose(condition, if_true, if_false):
    """if_true where condition holds, else if_false, elementwise (np.where): the choice a traced step can make."""
    return np.where(condition, if_true, if_false)


def dead_zone(x, width):
    """0 within [-width, width], else x moved towards 0 by width (continuous at the edges)."""
    return np.where(np.abs(x) <= width, 0.0 * x, x - np.sign(x) * width)


def rate_limit(x, previous, max_step):
    """x, moved from previous by at most max_step (per tick: keep previous as an attribute, held between ticks)."""
    return previous + np.clip(x - previous, -max_step, max_step)
