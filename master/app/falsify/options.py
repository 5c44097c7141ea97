"""The value types of a search's options, declared once: `tiltload falsify`'s parser takes them as its options'
types, tiltload.FalsifyOptions checks its fields by them (case/fields.py)."""

from __future__ import annotations

from ...command_line.argument_types import integer, positive_number, positive_time
from ..case.fields import Fields, whole_number

OPTIMIZERS = ("uniform", "cmaes", "tpe", "neldermead")  # the spec's optimizer and --optimizer

FALSIFY = Fields("falsify", {"seed": integer(0, 2**32 - 1), "simulations": integer(1, 1000000), "seconds": positive_time,
                             "workers": whole_number, "neighbourhood_fraction": positive_number,
                             "neighbourhood_points": integer(2, 15)},
                 {"optimizer": OPTIMIZERS, "branch": ("auto", "on", "off")})
