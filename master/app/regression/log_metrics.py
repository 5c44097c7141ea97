"""ISE and IADU recomputed from a log's messages, for a log whose metrics record is missing (a killed run).

Same definitions as engine/metrics.Metrics: ISE(v) = sum_k (v(t_k) - v_ref(t_k))^2 T over the controller's
ticks, with v(t_k) the plant's state at the start of tick k; IADU(u) = sum_k |u_k - u_{k-1}|.
"""

from __future__ import annotations

TRACKED = (("x", "x_ref"), ("y", "y_ref"), ("z", "z_ref"), ("psi", "psi_ref"))
INPUTS = ("f_R", "f_L", "tau_R", "tau_L")


def metrics_from_messages(data: dict[str, list[dict]], tick: float = 0.012, end: float | None = None) -> tuple[dict[str, float], float]:
    """(metrics, the last controller time used) from the /plant, /scenario and /controller messages. The controller's
    messages are its steps, from t = 0 (engine/edges.py); end: the stop time the run was asked for, at or after which
    a message is a closing sample, not a tick (None: every message is a tick's)."""
    plant = {round(m["t"], 6): m for m in data.get("/plant", [])}
    scenario = {round(m["t"], 6): m for m in data.get("/scenario", [])}
    ctrl = [m for m in data.get("/controller", []) if end is None or m["t"] < end - 1e-9]
    ise = dict.fromkeys(TRACKED, 0.0)
    iadu = dict.fromkeys(INPUTS, 0.0)
    prev, last = None, 0.0
    for m in ctrl:
        t = round(m["t"], 6)
        if t not in plant or t not in scenario:
            break  # the log ends inside this tick
        for v, ref in TRACKED:
            e = plant[t][v] - scenario[t][ref]
            ise[(v, ref)] += e * e * tick
        if prev is not None:
            for u in INPUTS:
                iadu[u] += abs(m[u] - prev[u])
        prev, last = m, m["t"]
    out = {f"ISE({v})": x for (v, _), x in ise.items()}
    out.update({f"IADU({u})": x for u, x in iadu.items()})
    return out, last
