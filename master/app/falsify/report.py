"""What a falsification leaves: the best case as a `tiltload run` command that replays it bit for bit (its fault file
beside it), the figure of the best robustness against the number of simulations, and a one-screen summary.

A requirement no evaluation violated is "not falsified in N simulations": a search is no proof."""

from __future__ import annotations

import json
import math
import shlex
from pathlib import Path

from ..loop.defaults import MAX_TILT, OUR_CONTROLLERS
from .search import Outcome
from .spec import Falsification

SUMMARY, FIGURE, FAULTS = "summary.txt", "best_robustness.png", "counterexample_faults.json"
MISSION = "counterexample_mission.csv"


def _number(value) -> str:
    """A value for --set that reads back as the same float (repr round-trips) or integer."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    text = repr(float(value))
    return text if ("." in text or "e" in text or "inf" in text or "nan" in text) else text + ".0"


def replay_case(spec: Falsification, row: dict, out: Path, fmus: Path | None = None) -> dict[str, object]:
    """The row's case as the fields of a tiltload.Case (in the order `tiltload run` prints them): the case as the
    evaluation ran it; writes its fault file (and a moved mission) in out."""
    from .space import case_faults, case_parameters, mission_csv, moved_waypoints

    base = spec.base()
    values = {d.name: row[d.name] for d in spec.dimensions}
    values = {d.name: (int(values[d.name]) if d.integer else float(values[d.name])) for d in spec.dimensions}
    parameters = case_parameters(base, values)
    trajectory = spec.trajectory_arg
    moved = moved_waypoints(base, parameters)
    if moved is not None:  # the moved mission as a file of its own
        (out / MISSION).write_text(mission_csv(moved))
        trajectory = str((out / MISSION).resolve())
        parameters = {k: v for k, v in parameters.items() if not k.startswith("waypoints.")}
    case: dict[str, object] = {"scenario": spec.scenario, "trajectory": trajectory, "controller": spec.controller,
                               "seed": spec.loop_seed, "stop_time": spec.stop_time, "no_gusts": not spec.gusts,
                               "wind": spec.wind_file, "allow_infeasible": spec.flight.allow_infeasible,
                               "max_tilt": spec.flight.max_tilt}
    faults = case_faults(base, parameters)
    if faults:
        (out / FAULTS).write_text(json.dumps({"faults": faults}, indent=1))
        case["faults"] = (out / FAULTS).resolve()
    case["set"] = tuple((k, v) for k, v in parameters.items() if not k.startswith("faults."))
    case["fmus"] = fmus
    return case


REPLAY_OUT = ("counterexample", "counterexample")  # the replay's log: <out>/counterexample/counterexample.mcap


def searched_fmus(spec: Falsification) -> tuple[tuple[str, str], ...]:
    """(instance, SHA-256) of the user's controller FMU the search ran: the replay refuses another build at its path
    (the loop's own FMUs are rebuilt from tiltload's sources and named by the log's record)."""
    from ...engine.log.provenance import fmu_digest
    from ..loop.thesis import CONTROLLER

    if spec.controller in OUR_CONTROLLERS:
        return ()
    return ((CONTROLLER, fmu_digest(Path(spec.controller))),)


def replay_command(spec: Falsification, row: dict, out: Path, fmus: Path | None = None) -> list[str]:
    """The `tiltload run` arguments that run the row's case as the evaluation ran it; writes its fault file in out."""
    case = replay_case(spec, row, out, fmus)
    args = ["tiltload", "run", "--scenario", str(case["scenario"]), "--trajectory", str(case["trajectory"]),
            "--controller", str(case["controller"]), "--seed", str(case["seed"]), "--stop-time", _number(case["stop_time"])]
    if case["no_gusts"]:
        args.append("--no-gusts")
    if case["wind"] is not None:
        args += ["--wind", str(case["wind"])]
    if case["allow_infeasible"]:
        args.append("--allow-infeasible")
    if case["max_tilt"] != MAX_TILT:
        args += ["--max-tilt", _number(case["max_tilt"])]
    if "faults" in case:
        args += ["--faults", str(case["faults"])]
    for key, value in case["set"]:
        args += ["--set", f"{key}={_number(value)}"]
    if fmus is not None:
        args += ["--fmus", str(fmus)]
    for instance, digest in searched_fmus(spec):  # pinned: a rebuild at the same path is refused, not replayed
        args += ["--expect-fmu", f"{instance}={digest}"]
    args += ["--out", str((out / REPLAY_OUT[0]).resolve()), "--name", REPLAY_OUT[1]]
    return args


def figure(curves: dict[str, list[float]], path: Path, title: str) -> Path:
    """Best robustness so far against simulations, one line per label (a search or an optimizer's seeds)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(7, 4.2))
    for label, values in curves.items():
        best = np.minimum.accumulate(np.asarray(values, dtype=float))
        ax.plot(np.arange(1, len(best) + 1), best, label=label, drawstyle="steps-post")
    ax.axhline(0.0, color="k", lw=0.8, ls="--")
    ax.set_xlabel("simulations")
    ax.set_ylabel("best robustness so far (units of the requirement's signal)")
    ax.set_title(title)
    ax.set_yscale("symlog", linthresh=0.01)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def whole_run(spec: Falsification, row: dict, fmus: Path) -> dict:
    """The row's case run to its stop time (no early stop, no branch): what its replay gives."""
    from .evaluate import evaluate
    from .space import case_parameters

    base = spec.base()
    values = {d.name: (int(row[d.name]) if d.integer else float(row[d.name])) for d in spec.dimensions}
    return evaluate(base, {"run_id": row["run_id"], "values": values, "parameters": case_parameters(base, values)},
                    str(fmus))["row"]


def summary(spec: Falsification, outcome: Outcome, command: list[str] | None, notes=(), whole: dict | None = None) -> str:
    from ..evidence.falsification_page import simulations  # the page's words: "1 simulation"

    n = outcome.simulations
    lines = [f"falsification {spec.name}: optimizer {spec.optimizer} (seed {spec.seed}), {len(spec.dimensions)} dimensions, "
             f"{simulations(n)} in {outcome.seconds:.1f} s" + (f" ({outcome.reused} from the previous run)" if outcome.reused else "")]
    for r in spec.requirements:
        lines.append(f"  requirement {r.name}: {r.formula}")
    lines.append("  search space: " + ", ".join(f"{d.name} = {d.target} in [{d.low:g}, {d.high:g}]" for d in spec.dimensions))
    best = outcome.best
    if outcome.falsified_at is not None and best is not None:
        k = outcome.falsified_at + 1
        lines.append(f"FALSIFIED after {simulations(k)}; the most negative robustness "
                     f"{best['robustness']:.6g} at:")
    else:
        lines.append(f"NOT FALSIFIED in {simulations(n)} (a search is no proof); lowest robustness "
                     f"{best['robustness']:.6g} at:" if best else f"NOT FALSIFIED in {simulations(n)} (none had a robustness)")
    failed = [r for r in outcome.rows if r.get("error")]
    if failed:  # the run's own line (a controller that raised, a diverged loop): what the user fixes
        lines.append(f"  {len(failed)} of {simulations(n)} ended in an error; the first: {failed[0]['error']}")
    if best is not None:
        lines.append("  " + ", ".join(f"{d.name} = {best[d.name]:.6g}" for d in spec.dimensions))
        for r in spec.requirements:
            rho = best.get(f"rho_{r.name}")
            lines.append(f"  {r.name}: robustness {rho:.6g} ({best.get(f'verdict_{r.name}')})" if rho is not None and not
                         math.isnan(rho) else f"  {r.name}: no robustness ({best.get('error')})")
        if best.get("error"):
            lines.append(f"  the run ended early: {best['error']}")
        stopped = best.get("stopped_at")
        if stopped is not None and not math.isnan(stopped):
            lines.append(f"  its evaluation stopped at t = {stopped:.3f} s, the violation decided: the robustness above is the "
                         "upper bound over every continuation (the value at the stop)")
            if whole is not None:
                lines.append(f"  the whole run (what replay.sh runs): robustness {whole['robustness']!r}")
    lines.extend(notes)
    if command:
        lines.append("replay it:")
        lines.append("  " + shlex.join(command))
    return "\n".join(lines)


def write(spec: Falsification, outcome: Outcome, out: Path, fmus: Path | None = None, notes=()) -> str:
    best = outcome.best
    stopped = best.get("stopped_at") if best is not None else None
    whole = whole_run(spec, best, fmus) if fmus is not None and stopped is not None and not math.isnan(stopped) else None
    command = replay_command(spec, best, out, fmus) if best is not None else None
    if command:
        (out / "replay.sh").write_text("#!/bin/sh\n" + shlex.join(command) + "\n")
    curves = {f"{spec.optimizer} (seed {spec.seed})": [r["robustness"] if r.get("robustness") is not None
                                                       and not math.isnan(r["robustness"]) else math.inf for r in outcome.rows]}
    if outcome.rows:
        figure(curves, out / FIGURE, f"{spec.name}: best robustness against simulations")
    text = summary(spec, outcome, command, notes, whole)
    (out / SUMMARY).write_text(text + "\n")
    return text


def html_report(spec: Falsification, outcome: Outcome, out: Path, command: list[str] | None, text: str,
                log: Path | None):
    """report.html: the search, and its best case (log: that case replayed with a log) judged with its figures; the
    report written (evidence.model.Report)."""
    from ...engine.requirement.files import requirement
    from ..evidence.falsification_page import falsification_report
    from ..evidence.page import write_report

    figures = [out / FIGURE, out / "neighbourhood" / "neighbourhood.png", out / "neighbourhood.png"]
    dims = [(d.name, d.target, float(d.low), float(d.high)) for d in spec.dimensions]
    reqs = [requirement(r.name, r.formula, description=r.description) for r in spec.requirements]
    page = falsification_report(spec.name, text, reqs, dims, outcome.rows, outcome.falsified_at, command, log, figures)
    write_report(page, Path(out) / "report.html")
    return page
