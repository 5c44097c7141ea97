"""The FMUs a campaign ran, recorded beside its results (<out>/fmus.json) and read by its report: for each controller,
the FMUs of its first case's system (case.record.fmus_of_system), computed once by the client. A worker's runs log
theirs too, but a campaign keeps no logs by default, and its results hold rows, not records."""

from __future__ import annotations

import json
from pathlib import Path

from ..case.record import FmuRecord, fmus_of_system
from ..loop.defaults import OUR_CONTROLLERS
from .spec import Campaign

FMUS = "fmus.json"


def controller_label(controller: str) -> str:
    """A controller as the results' controller column names it (a user's FMU by its stem)."""
    return controller if controller in OUR_CONTROLLERS else Path(controller).stem


def record_fmus(campaign: Campaign, fmus: Path, out: Path) -> None:
    """<out>/fmus.json: {controller: {"fmus": [each instance's FmuRecord], "controller_parameters": {...}}}."""
    from ..case.system import branch_system, case_system

    firsts: dict = {}
    for case in campaign.cases:
        firsts.setdefault(case.controller, case)
    base, snap = campaign.base(), None
    if campaign.snapshot is not None:
        from ...engine import snapshot

        snap = snapshot.read(campaign.snapshot)
    data = {}
    for controller, case in firsts.items():
        system = (case_system(Path(fmus), base, controller, case.seed, case.parameters) if snap is None else
                  branch_system(Path(fmus), snap, campaign.faults, case.parameters, controller)[0])
        records, parameters = fmus_of_system(system)
        data[controller_label(controller)] = {"fmus": [vars(r) for r in records], "controller_parameters": dict(parameters)}
    (out / FMUS).write_text(json.dumps(data, indent=1) + "\n")


def recorded_fmus(folder: Path) -> tuple[tuple[FmuRecord, ...], tuple[tuple[str, str], ...]]:
    """The FMUs fmus.json names (each controller's FMU as `controller (its name)` when the campaign ran several), and
    the controller's parameters when it ran one; empty for results without the file (an older campaign's)."""
    path = Path(folder) / FMUS
    try:
        data = json.loads(path.read_text())
        per_controller = {str(c): ([FmuRecord(**{k: str(f[k]) for k in ("instance", "model", "guid", "sha256", "path")})
                                    for f in v["fmus"]], v.get("controller_parameters", {})) for c, v in data.items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return (), ()
    records: dict[tuple[str, str], FmuRecord] = {}
    for label, (fmus, _) in per_controller.items():
        for f in fmus:
            if f.instance == "controller" and len(per_controller) > 1:
                f = FmuRecord(f"controller ({label})", f.model, f.guid, f.sha256, f.path)
            records.setdefault((f.instance, f.sha256), f)
    parameters = next(iter(per_controller.values()))[1] if len(per_controller) == 1 else {}
    return tuple(records.values()), tuple(sorted((str(k), str(v)) for k, v in parameters.items()))


def fmu_section(fmus) -> list[str]:
    """The FMUs the campaign ran (fmus.json), or a line saying the results do not record them."""
    if not fmus:
        return ["## FMUs", "", f"Not recorded beside these results (no {FMUS}: a campaign of an older tiltload).", ""]
    return ["## FMUs", "", "| instance | model | SHA-256 |", "|---|---|---|",
            *(f"| {f.instance} | {f.model} | `{f.sha256}` |" for f in fmus), ""]


def controller_digests(folder: Path) -> dict[str, str]:
    """{controller label: its FMU's SHA-256} of a user's controller FMUs fmus.json records (rerun commands pin them)."""
    try:
        data = json.loads((Path(folder) / FMUS).read_text())
        return {str(label): str(f["sha256"]) for label, v in data.items() if label not in OUR_CONTROLLERS
                for f in v["fmus"] if f["instance"] == "controller"}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}
