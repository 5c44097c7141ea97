"""The thesis's designs for a controller of your own: DLQR, pure H-infinity and mixed H2/H-infinity with the LMI pole
regions (docs/design_api.md).

    import tiltload as tl

    lqr = tl.design.dlqr()                       # the thesis's DLQR: lqr.K, lqr.poles, lqr.Q, lqr.R, lqr.model
    robust = tl.design.mixed(delay_ticks=1)      # the shipped mixed design for a one-tick loop delay
"""

from __future__ import annotations

from .master.app.api.design import REGIONS, Design, dlqr, hinf, mixed, weights

__all__ = ["REGIONS", "Design", "dlqr", "hinf", "mixed", "weights"]
