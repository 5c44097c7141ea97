"""tiltload: FMI co-simulation of a tilt-rotor UAV carrying a suspended load (Rego, UFMG 2016).

The public API (docs/api.md)::

    import tiltload as tl

    result = tl.run(tl.Case(scenario="lkf", trajectory=2, stop_time=10))   # or the same as keywords: tl.run(scenario=...)
    result.metrics["ISE(x)"], result.signals("/plant")["x"], result.to_dataframe("/plant"), result.command
    tl.compare(result, "baselines/lkf_traj2.json").ok              # the case first, then the metrics
    tl.compare_signals(result, "baselines/lkf_traj2.parquet").ok   # each signal in its tolerance tube
    tl.check(result, "docs/requirements/thesis.yaml")                # each requirement's verdict and robustness
    tl.b2b("reproduction", candidate=tl.B2BSide(stage="pil")).table()  # back to back: SIL against PIL, in tubes
    tl.campaign("docs/campaigns/robustness.toml", workers=2)
    tl.falsify("docs/falsification/swing_gust.toml", simulations=20).best
    tl.plant.trim(), tl.plant.linearize(dt=tl.plant.TICK), tl.design.dlqr(), tl.design.mixed()   # docs/design_api.md
    tl.saturate(u, lo, hi), tl.choose(e > 0, a, b), tl.dead_zone(e, w), tl.rate_limit(u, u_prev, du)  # trace into C

Errors the user can fix raise TiltloadError, its message the line the `tiltload` command prints. Everything else
(tiltload.master, tiltload.plant_fmu, ...) is the implementation, not the API. The names load on first use, so
that `import tiltload` (and the pytest plugin, loaded in every pytest run) costs nothing.
"""

from __future__ import annotations

import sys
from importlib import import_module
from importlib.machinery import ModuleSpec
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from . import design, plant
    from .master.app.api.back_to_back import B2BCase, B2BSide, BackToBack, b2b
    from .master.app.api.campaigns import CampaignOptions, CampaignResult, campaign
    from .master.app.api.case import Case
    from .master.app.api.checking import check
    from .master.app.api.comparing import compare, save_baseline
    from .master.app.api.errors import TiltloadError
    from .master.app.api.falsifying import FalsifyOptions, FalsifyResult, falsify
    from .master.app.api.python_controller import PythonController
    from .master.app.api.result import Result, Signals, open_log
    from .master.app.api.run_options import RunOptions
    from .master.app.api.running import run
    from .master.app.api.signal_comparing import compare_signals, save_signal_baseline
    from .master.app.api.signals import choose, dead_zone, rate_limit, saturate
    from .master.app.regression.compare import Comparison, MetricRow
    from .master.app.regression.signal_compare import SignalComparison

_API = "tiltload.master.app.api."
_PUBLIC = {  # name: the module it is defined in
    "run": _API + "running", "Result": _API + "result", "open_log": _API + "result", "Signals": _API + "result",
    "compare": _API + "comparing",
    "save_baseline": _API + "comparing", "campaign": _API + "campaigns", "CampaignResult": _API + "campaigns", "check": _API + "checking",
    "TiltloadError": _API + "errors", "Case": _API + "case", "RunOptions": _API + "run_options",
    "PythonController": _API + "python_controller",
    "CampaignOptions": _API + "campaigns", "falsify": _API + "falsifying", "FalsifyOptions": _API + "falsifying",
    "FalsifyResult": _API + "falsifying", "Comparison": "tiltload.master.app.regression.compare",
    "MetricRow": "tiltload.master.app.regression.compare", "compare_signals": _API + "signal_comparing",
    "save_signal_baseline": _API + "signal_comparing", "SignalComparison": "tiltload.master.app.regression.signal_compare",
    "b2b": _API + "back_to_back", "B2BSide": _API + "back_to_back", "B2BCase": _API + "back_to_back",
    "BackToBack": _API + "back_to_back",
    "saturate": _API + "signals", "choose": _API + "signals", "dead_zone": _API + "signals",
    "rate_limit": _API + "signals",
}
_NAMESPACES = ("plant", "design")  # modules of their own (tiltload/plant.py, design.py): tl.plant.trim(), tl.design.dlqr()
__all__ = ["B2BCase", "B2BSide", "BackToBack", "CampaignOptions", "CampaignResult", "Case", "Comparison", "FalsifyOptions",
           "FalsifyResult", "MetricRow", "PythonController", "Result", "RunOptions", "SignalComparison", "Signals", "TiltloadError",
           "b2b", "campaign", "check", "compare", "compare_signals", "falsify", "open_log",
           "run", "save_baseline", "save_signal_baseline", "plant", "design", "saturate", "choose", "dead_zone",
           "rate_limit"]


if "grimp" in sys.modules:  # import-linter is building its graph (pyproject.toml [tool.importlinter])
    # grimp accepts the portions (tiltload.master, ...) as root packages only under a namespace package: in that process,
    # tiltload's spec is a namespace's (no location), its submodules found as before
    __spec__ = ModuleSpec(__name__, None, is_package=True)
    __spec__.submodule_search_locations = list(__path__)


def __getattr__(name: str) -> object:
    if name in _NAMESPACES:
        return import_module(f"{__name__}.{name}")  # the import binds it here too
    where = _PUBLIC.get(name)
    if where is None:
        raise AttributeError(f"module 'tiltload' has no attribute {name!r}")
    value = getattr(import_module(where), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
