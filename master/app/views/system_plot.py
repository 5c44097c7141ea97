"""A `--system` run's figure from its MCAP log: each FMU's numeric outputs over time, one panel per FMU, their units
from the log's own record (the loop's figures, plot.py, are for the thesis's loop and need its /plant channel)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ...engine.log import reader as log_reader  # noqa: E402

MAX_PANELS = 12  # FMUs drawn; a larger system's others are said in the title


def _numeric(msgs: list[dict]) -> dict[str, tuple[np.ndarray, bool]]:
    """{output: (values, held)} of the numbers and Booleans among an instance's messages (held: drawn as steps)."""
    out = {}
    for name in msgs[0]:
        if name == "t":
            continue
        values = [m.get(name) for m in msgs]
        if all(isinstance(v, bool) for v in values):
            out[name] = (np.array(values, dtype=float), True)
        elif all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            out[name] = (np.array(values, dtype=float), all(isinstance(v, int) for v in values))
    return out


def plot_system_run(log: Path, out: Path | None = None, case: str = "", data: dict | None = None) -> list[Path]:
    """<stem>_outputs.png next to the log (or into out): each instance's numeric outputs against t; none for a log
    with no numeric output. case titles the figure; data: the log's messages, read already (a damaged log's intact
    part)."""
    log = Path(log)
    fig = outputs_figure(log, case, data)
    if fig is None:
        return []
    path = (log.parent if out is None else Path(out)) / f"{log.stem}_outputs.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def outputs_figure(log: Path, case: str = "", data: dict | None = None):
    """The figure of plot_system_run (a run's report shows it too), or None for a log with no numeric output."""
    log = Path(log)
    data = log_reader.read(log) if data is None else data
    units = log_reader.read_metadata(log).get("units", {})
    panels = [(topic, _numeric(msgs), msgs) for topic, msgs in sorted(data.items())
              if msgs and "t" in msgs[0] and topic.count("/") == 1]
    panels = [p for p in panels if p[1]]
    if not panels:
        return None
    shown = panels[:MAX_PANELS]
    fig, axes = plt.subplots(len(shown), 1, figsize=(9, 2.4 * len(shown) + 0.8), sharex=True, squeeze=False)
    for ax, (topic, series, msgs) in zip(axes[:, 0], shown):
        instance = topic.lstrip("/")
        t = np.array([m["t"] for m in msgs], dtype=float)
        for name, (values, held) in series.items():
            unit = units.get(f"{instance}.{name}")
            ax.plot(t, values, drawstyle="steps-post" if held else "default", label=f"{name} [{unit}]" if unit else name)
        ax.set_ylabel(f"{instance}\n(units: legend)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=max(1, len(series) // 8), loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1, 0].set_xlabel("t [s]")
    more = f" (the first {MAX_PANELS} of {len(panels)} FMUs)" if len(panels) > MAX_PANELS else ""
    fig.suptitle(f"{case or log.stem}: each FMU's outputs{more}")
    fig.tight_layout()
    return fig
