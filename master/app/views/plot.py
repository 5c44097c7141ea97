"""The thesis's kinds of figures from a run's MCAP log, as PNG files."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ....plant_fmu import parameters  # noqa: E402
from ...engine.log import reader as log_reader  # noqa: E402


def _series(msgs: list[dict], *names: str) -> np.ndarray:
    return np.array([[np.nan if m.get(n) is None else m[n] for n in names] for m in msgs], dtype=float)


def fault_intervals(events: list[dict], t_end: float) -> list[tuple[float, float, str]]:
    """(start, end, name) of each fault from the /faults events; a fault still on at the end lasts to t_end."""
    started, out = {}, []
    for e in events:
        if e["event"] == "start":
            started[e["name"]] = e["t"]
        elif e["name"] in started:
            out.append((started.pop(e["name"]), e["t"], e["name"]))
    out += [(t0, t_end, name) for name, t0 in started.items()]
    return sorted(out)


TOPICS = ["/plant", "/scenario", "/controller", "/faults"]
_LIMIT = {s.name: s.default for s in parameters.ACTUATOR_LIMITS}  # Table 5.2, the plant's defaults
ACTUATOR_LIMITS = {"f_R": (_LIMIT["f_min"], _LIMIT["f_max"]), "f_L": (_LIMIT["f_min"], _LIMIT["f_max"]),
                   "tau_R": (-_LIMIT["tau_max"], _LIMIT["tau_max"]), "tau_L": (-_LIMIT["tau_max"], _LIMIT["tau_max"])}


def plot_run(log: Path, out: Path | None = None) -> list[Path]:
    """Write <stem>_*.png next to the log (or into out); returns the files written. A damaged log raises
    log_reader.DamagedLog (plot_intact draws the intact part of one)."""
    if is_system_run(log):  # a --system run: its FMUs' outputs (system_plot.py), not the loop's figures
        from .system_plot import plot_system_run

        return plot_system_run(Path(log), out, case_of(log)) + requirement_figure(Path(log), out)
    files = plot_messages(log_reader.read(log, topics=TOPICS), Path(log), out, case_of(log))
    return files + requirement_figure(Path(log), out)


def is_system_run(log: Path) -> bool:
    """The log is of a `--system` run (its run record says so): drawn as its FMUs' outputs, not the loop's figures."""
    try:
        return bool(log_reader.read_metadata(Path(log)).get("run", {}).get("system"))
    except Exception:  # a record the reader cannot parse: drawn as the loop's, which says what is missing
        return False


def requirement_figure(log: Path, out: Path | None = None) -> list[Path]:
    """<stem>_requirements.png for a run monitored with --requirements: each requirement's margin over time (for
    always[a:b] φ, the robustness of φ), its violations shaded, its signals named; none for a log without them."""
    from ...engine.requirement.check import build_trace, intervals, margins
    from ...engine.requirement.files import requirement

    meta = log_reader.read_metadata(log)
    formulas, verdicts = meta.get("requirement_formulas"), meta.get("requirements", {})
    if not formulas:
        return []
    reqs = [requirement(name, text) for name, text in formulas.items()]
    columns, state = log_reader.read_columns(log, sorted({f"/{n.split('.')[0]}" for r in reqs for n in r.signals}))
    series = {topic.lstrip("/"): c for topic, c in columns.items()}
    fig, axes = plt.subplots(len(reqs), 1, figsize=(8, 1.8 * len(reqs) + 0.6), sharex=True, squeeze=False)
    cache: dict = {}
    for ax, req in zip(axes[:, 0], reqs):
        times, margin = margins(req, build_trace(series, req.signals, cache), final=not state.torn and "error" not in meta)
        ax.plot(times, margin, lw=1)
        ax.axhline(0.0, color="k", lw=0.6)
        for k, (t0, t1) in enumerate(intervals(times, margin < 0)):
            ax.axvspan(t0, t1, color="C3", alpha=0.25, lw=0, label="violated" if k == 0 else None)
        ax.set_title(f"{req.name}: {verdicts.get(req.name, '').split(' ')[0]}  ({', '.join(req.signals)})", fontsize=8)
        ax.set_ylabel("margin", fontsize=8)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("t (s)")
    case = case_of(log)
    fig.suptitle(f"Requirements: margin over time (robustness, in each signal's unit)\n{case}" if case else
                 "Requirements: margin over time (robustness, in each signal's unit)", fontsize=10)
    fig.tight_layout()
    out = log.parent if out is None else Path(out)
    path = out / f"{log.stem}_requirements.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def plot_intact(log: Path, out: Path | None = None) -> tuple[list[Path], log_reader.LogState]:
    """The figures of what the log holds intact (all of it, up to a torn end, or up to the damage), and its state."""
    if is_system_run(log):
        from .system_plot import plot_system_run

        data, state = log_reader.read_checked(log)
        return plot_system_run(Path(log), out, case_of(log), data), state
    data, state = log_reader.read_checked(log, topics=TOPICS)
    if state.damage is not None and not data.get("/plant"):
        raise log_reader.DamagedLog(state.describe(Path(log)) + ": nothing to draw")
    return plot_messages(data, Path(log), out, case_of(log)), state


def case_of(log: Path) -> str:
    """The case a log holds, from its "run" record (empty for a log without one)."""
    try:
        return case_title(log_reader.read_metadata(Path(log)).get("run", {}))
    except Exception:  # a record the reader cannot parse: the figures are drawn without their case, not refused
        return ""


def case_title(run: dict) -> str:
    """What sets a run apart, as a figure's title says it: 'UAV with load, scenario zse, trajectory 1, controller mixed,
    seed 1'; a system file's name; the faults file and parameters set, when any."""
    if run.get("system"):
        parts = [f"system {Path(run['system']).name}"]
    elif "vehicle" not in run:  # a log from before the run record listed its options: its case's name
        parts = [run.get("case", "")]
    else:
        parts = [{"load": "UAV with load", "uav": "UAV alone"}.get(run.get("vehicle", ""), run.get("vehicle", "")),
                 run.get("scenario") and f"scenario {run['scenario']}",
                 run.get("trajectory") and f"trajectory {run['trajectory']}",
                 run.get("controller") and f"controller {Path(run['controller']).name}",
                 run.get("seed") and f"seed {run['seed']}",
                 "1-tick delay" if run.get("delay") == "True" else "", "no gusts" if run.get("gusts") == "False" else "",
                 "FMI 3.0" + (" clocks" if run.get("clocks") == "True" else "") if run.get("fmi") == "3" else ""]
    if run.get("set"):
        parts.append(settings_brief(str(run["set"])))
    if run.get("faults"):
        parts.append(f"faults {Path(run['faults']).name}")
    return ", ".join(p for p in parts if p)


def settings_brief(settings: str, most: int = 2, width: int = 60) -> str:
    """--set values for a title: the first `most` whole (each cut at width), then how many more; a title never runs off
    the figure's sides."""
    items = settings.split()
    shown = [item if len(item) <= width else item[:width - 1] + "…" for item in items[:most]]
    more = len(items) - len(shown)
    return "set " + ", ".join(shown) + (f" (+{more} more)" if more else "")


def plot_messages(data: dict[str, list[dict]], log: Path, out: Path | None = None, case: str = "") -> list[Path]:
    """Write <log stem>_*.png from the log's messages next to the log (or into out); case titles every figure."""
    out = log.parent if out is None else Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if not data.get("/plant"):
        raise ValueError(f"{log} has no /plant channel: not a tiltload loop log")
    files = []
    for name, fig in figures(data, case):
        path = out / f"{log.stem}_{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        files.append(path)
    return files


def unit(name: str) -> str:
    """The SI unit of a plant state or input by its name (docs/ports.md)."""
    if name in ("f_R", "f_L", "d_x", "d_y", "d_z"):
        return "N"
    if name in ("tau_R", "tau_L"):
        return "N m"
    base, rate = (name[:-4], True) if name.endswith("_dot") else (name, False)
    length = base in ("x", "y", "z", "x_B", "y_B", "z_B")
    return ("m" if length else "rad") + ("/s" if rate else "")


TITLES = {"trajectory3d": "trajectory", "tracking_error": "tracking error (reference - actual)",
          "disturbances": "disturbance force", "remaining_dof": "the remaining degrees of freedom",
          "actuators": "actuator inputs (red: the actuator limits, Table 5.2)", "estimation_error": "estimation error",
          "estimation_error_rest": "estimation error, the other states", "zse_frobenius": "the ZSE's zonotope size"}


BLOWUP = 1e6  # a value this many times the signal's usual size (or past any finite value) is a divergence, not data


def sane_part(times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, float | None]:
    """(the samples before a divergence, its time or None). A signal's usual size is the 99th percentile of |v| over
    its first 80 % of finite samples (at least 1e-6); a divergence is the first sample beyond BLOWUP times that, or not
    finite. A signal that does not diverge is kept whole."""
    values = np.asarray(values, dtype=float)
    finite = np.isfinite(values)
    if not len(values):
        return np.ones(0, bool), None
    usual = np.abs(values[finite][: max(1, int(0.8 * finite.sum()))]) if finite.any() else np.zeros(1)
    size = max(float(np.percentile(usual, 99)) if len(usual) else 0.0, 1e-6)
    wild = ~finite | (np.abs(np.where(finite, values, 0.0)) > BLOWUP * size)
    if not wild.any():
        return np.ones(len(values), bool), None
    first = int(np.argmax(wild))
    keep = np.zeros(len(values), bool)
    keep[:first] = True
    return keep, float(times[first])


def scale_to_sane(ax) -> float | None:
    """Scale an axis to its lines' samples before any divergence and mark the divergence's time (the earliest of its
    lines'); a figure of a diverged run then shows the run, not one spike to 1e90. Returns that time or None."""
    spans, when = [], []
    for line in ax.get_lines():
        x, y = np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)
        if len(x) != len(y) or len(y) < 2:
            continue
        keep, t = sane_part(x, y)
        if t is None:
            continue
        when.append(t)
        if keep.any():
            spans.append((float(np.min(y[keep])), float(np.max(y[keep]))))
    if not when:
        return None
    for line in ax.get_lines():  # the other lines' ranges count too
        y = np.asarray(line.get_ydata(), dtype=float)
        keep, _ = sane_part(np.arange(len(y)), y)
        if keep.any():
            spans.append((float(np.min(y[keep])), float(np.max(y[keep]))))
    if spans:
        lo, hi = min(a for a, _ in spans), max(b for _, b in spans)
        pad = 0.08 * max(hi - lo, 1e-9)
        ax.set_ylim(lo - pad, hi + pad)
    t = min(when)
    ax.axvline(t, color="m", lw=1.0, ls=":")
    ax.text(t, 0.97, f" diverged at {t:.3f} s", transform=ax.get_xaxis_transform(), fontsize=7, color="m", va="top",
            ha="right" if t > np.mean(ax.get_xlim()) else "left")
    return t


def limit_view(values: np.ndarray, limits: tuple[float, float], near: float = 0.5) -> tuple[tuple[float, float], list[float],
                                                                                         list[float]]:
    """The y range of a trace with actuator limits: (ylim, the limits to draw, the limits left out).

    The axis is scaled to the data (padded 8 %); a limit is drawn when it lies within the data's range widened by
    `near` of its span, and then the view stretches to show it; a limit farther away would flatten the trace to a line,
    so the figure names it in a note instead."""
    finite = values[np.isfinite(values)]
    if not len(finite):
        return (limits[0], limits[1]), list(limits), []
    lo, hi = float(finite.min()), float(finite.max())
    span = max(hi - lo, 1e-6 * max(abs(lo), abs(hi), 1.0))
    shown = [b for b in limits if lo - near * span <= b <= hi + near * span]
    far = [b for b in limits if b not in shown]
    lo, hi = min([lo, *shown]), max([hi, *shown])
    pad = 0.08 * max(hi - lo, span)
    return (lo - pad, hi + pad), shown, far


def figures(data: dict[str, list[dict]], case: str = ""):
    """(name, matplotlib figure) of each of the thesis's kinds of figures the messages allow, every axis with its unit;
    faults shaded on every time axis; each titled with what it shows and the case (a run's scenario, trajectory,
    controller, seed: case_title)."""
    plant, scen, ctrl = data["/plant"], data.get("/scenario", []), data.get("/controller", [])
    tp = _series(plant, "t")[:, 0]
    intervals = fault_intervals(data.get("/faults", []), float(tp[-1]) if len(tp) else 0.0)

    def done(fig, name):
        for ax in fig.axes:  # faults as shaded intervals on every time axis
            if ax.name != "3d":
                scale_to_sane(ax)
                for k, (t0, t1, label) in enumerate(intervals):
                    ax.axvspan(t0, t1, color=f"C{3 + k % 6}", alpha=0.15, lw=0, label=label if ax is fig.axes[0] else None)
        if intervals and fig.axes and fig.axes[0].name != "3d":
            fig.axes[0].legend(fontsize=7, loc="upper right")
        title = TITLES[name][0].upper() + TITLES[name][1:]
        fig.suptitle(f"{title}\n{case}" if case else title, fontsize=10)
        fig.tight_layout()
        return name, fig

    with_load = "gamma_1" in plant[0]  # else the UAV alone (Appendix A): Figs. A.2-A.8
    load, uav = _series(plant, "x", "y", "z"), _series(plant, "x_B", "y_B", "z_B")
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    ax.plot(*uav.T, label="UAV")
    if with_load:
        ax.plot(*load.T, label="load")
    if scen:
        ref = _series(scen, "x_ref", "y_ref", "z_ref")
        ax.plot(*ref.T, "k--", lw=0.8, label="reference")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.legend()
    yield done(fig, "trajectory3d")

    if scen:
        ts = _series(scen, "t")[:, 0]
        ref = _series(scen, "x_ref", "y_ref", "z_ref", "psi_ref")
        fig, axes = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
        for i, (ax, label) in enumerate(zip(axes, ("x (m)", "y (m)", "z (m)", "ψ (rad)"))):
            actual = np.interp(ts, tp, _series(plant, ("x", "y", "z", "psi")[i])[:, 0])
            ax.plot(ts, ref[:, i] - actual)
            ax.set_ylabel(f"error {label}")
            ax.grid(alpha=0.3)
        axes[-1].set_xlabel("t (s)")
        yield done(fig, "tracking_error")

        if "d_x" in scen[0]:
            fig, axes = plt.subplots(3, 1, figsize=(8, 6), sharex=True)
            for ax, n in zip(axes, ("d_x", "d_y", "d_z")):
                ax.plot(ts, _series(scen, n)[:, 0])
                ax.set_ylabel(f"{n} (N)")
                ax.grid(alpha=0.3)
            axes[0].set_title(f"disturbance force on the {'load' if with_load else 'UAV'}")
            axes[-1].set_xlabel("t (s)")
            yield done(fig, "disturbances")

    names = ("phi", "theta", "gamma_1", "gamma_2", "alpha_R", "alpha_L") if with_load else ("phi", "theta", "alpha_R", "alpha_L")
    fig, axes = plt.subplots(len(names) // 2, 2, figsize=(9, 7), sharex=True)
    for ax, n in zip(axes.ravel(), names):
        ax.plot(tp, _series(plant, n)[:, 0])
        ax.set_ylabel(f"{n} ({unit(n)})")
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    yield done(fig, "remaining_dof")

    if ctrl and "f_R" in ctrl[0]:
        tc = _series(ctrl, "t")[:, 0]
        fig, axes = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
        for ax, n in zip(axes, ("f_R", "f_L", "tau_R", "tau_L")):
            values = _series(ctrl, n)[:, 0]
            ax.step(tc, values, where="post")
            ylim, shown, far = limit_view(values, ACTUATOR_LIMITS[n])
            for b in shown:
                ax.axhline(b, color="r", ls=":")
            ax.set_ylim(*ylim)
            if far:  # drawn, they would flatten the trace: named instead
                ax.text(0.99, 0.96, f"limit{'s' if len(far) > 1 else ''} {' and '.join(f'{b:g}' for b in far)} {unit(n)} "
                        "off the scale", transform=ax.transAxes, ha="right", va="top", fontsize=7, color="r")
            ax.set_ylabel(f"{n} ({unit(n)})")
            ax.grid(alpha=0.3)
        axes[-1].set_xlabel("t (s)")
        yield done(fig, "actuators")

    if ctrl and "est_x" in ctrl[0]:
        ctrl = [m for m in ctrl if m["est_x_hi"] != m["est_x_lo"]] or ctrl  # not the message before the first estimate
        tc = _series(ctrl, "t")[:, 0]

        def estimation_figure(states, name, columns=1):
            rows = -(-len(states) // columns)
            fig, axes = plt.subplots(rows, columns, figsize=(8 if columns == 1 else 11, 2.3 * rows + 0.5), sharex=True,
                                     squeeze=False)
            for ax, n in zip(axes.ravel(), states):
                truth = np.interp(tc, tp, _series(plant, n)[:, 0])
                est, lo, hi = (_series(ctrl, f"est_{n}{s}")[:, 0] for s in ("", "_lo", "_hi"))
                ax.plot(tc, est - truth, label="estimation error")
                ax.plot(tc, lo - truth, "k--", lw=0.7, label="confidence limits")
                ax.plot(tc, hi - truth, "k--", lw=0.7)
                ax.set_ylabel(f"{n} error ({unit(n)})")
                ax.grid(alpha=0.3)
            axes[0][0].legend(fontsize=7)
            for ax in axes[-1]:
                ax.set_xlabel("t (s)")
            return done(fig, name)

        if with_load:
            yield estimation_figure(("x", "y", "z"), "estimation_error")
        else:  # Fig. A.7: x, y and their rates (the GPS pattern); Fig. A.8: the other states
            yield estimation_figure(("x", "y", "x_dot", "y_dot"), "estimation_error")
            rest = ("z", "phi", "theta", "psi", "alpha_R", "alpha_L", "z_dot", "phi_dot", "theta_dot", "psi_dot",
                    "alpha_R_dot", "alpha_L_dot")
            yield estimation_figure(rest, "estimation_error_rest", columns=3)
        frob = _series(ctrl, "zse_G_frobenius")[:, 0]
        if np.nanmax(np.abs(frob)) > 0:
            fig, ax = plt.subplots(figsize=(8, 3))
            ax.plot(tc, frob)
            ax.set_xlabel("t (s)")
            ax.set_ylabel(r"$\Vert G \Vert_F$ (mixed state units)")  # the zonotope's size: G's rows mix m, rad, ...
            ax.grid(alpha=0.3)
            yield done(fig, "zse_frobenius")
