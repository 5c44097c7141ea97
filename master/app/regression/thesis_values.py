"""The thesis's performance indexes (Tables 5.4-5.7, 5.9, 5.10), for side-by-side comparison.

Keyed by (scenario, trajectory, controller); values in the order of METRICS.
"""

from __future__ import annotations

METRICS = ("ISE(x)", "ISE(y)", "ISE(z)", "ISE(psi)", "IADU(f_R)", "IADU(f_L)", "IADU(tau_R)", "IADU(tau_L)")

_TABLES = {  # (scenario, trajectory): {controller: values}, table number
    ("fsi", 1): ("5.4", {"dlqr": (0.1571, 0.1111, 0.0428, 1.1519e-4, 7.1486, 7.7712, 0.1984, 0.1982),
                         "mixed": (0.1521, 0.1167, 0.0385, 3.6213e-4, 7.9463, 9.6864, 0.1966, 0.1978)}),
    ("fsi", 2): ("5.5", {"dlqr": (0.3358, 0.2330, 1.0441e-3, 5.1167e-3, 24.2162, 24.1251, 0.2849, 0.2716),
                         "mixed": (0.2987, 0.2326, 1.6637e-3, 9.4917e-3, 27.2654, 26.8009, 0.3020, 0.2867)}),
    ("lkf", 1): ("5.6", {"dlqr": (0.1624, 0.1196, 0.0493, 4.2886e-3, 208.6821, 207.4649, 5.4937, 5.4901),
                         "mixed": (0.1700, 0.1385, 0.0380, 6.4845e-3, 275.6098, 297.4057, 5.1566, 5.3431)}),
    ("lkf", 2): ("5.7", {"dlqr": (0.3523, 0.2519, 0.0139, 0.0178, 270.2537, 268.2610, 6.8655, 6.8335),
                         "mixed": (0.2977, 0.2799, 0.0165, 0.0813, 366.4055, 381.9623, 6.3388, 6.4827)}),
    ("zse", 1): ("5.9", {"dlqr": (0.4146, 0.2895, 0.1389, 3.8434e-3, 302.6595, 314.6170, 7.3176, 7.3531),
                         "mixed": (0.2580, 0.1801, 0.1326, 4.4799e-3, 408.7079, 407.7327, 6.0647, 6.4135)}),
    ("zse", 2): ("5.10", {"dlqr": (0.5242, 0.3347, 0.1123, 0.0123, 406.9815, 404.0254, 8.9879, 9.0586),
                          "mixed": (0.4225, 0.3443, 0.1529, 0.0161, 518.4401, 516.2678, 7.4309, 7.7548)}),
}


def table_number(scenario: str, trajectory: int) -> str:
    return _TABLES[(scenario, trajectory)][0]


def thesis(scenario: str, trajectory: int, controller: str) -> dict[str, float]:
    return dict(zip(METRICS, _TABLES[(scenario, trajectory)][1][controller]))


def beside_run(opts, stop: float) -> tuple[str, dict[str, float] | None]:
    """What `tiltload run` prints beside its metrics: ("Table 5.x", the thesis's values) for a run of a thesis case as
    the thesis ran it (the loop, the load, FSI/LKF/ZSE, trajectory 1 or 2, DLQR or mixed, gusts, no delay, fault, wind
    or --set, the full length); (a note, None) for that case cut short; ("", None) for any other run."""
    from ..loop.thesis import default_stop

    case = (getattr(opts, "system", None) is None and opts.vehicle == "load" and opts.trajectory in (1, 2)
            and (opts.scenario, opts.trajectory) in _TABLES and opts.controller in ("dlqr", "mixed") and opts.gusts
            and not opts.delay and opts.faults is None and getattr(opts, "wind", None) is None and not opts.settings)
    if not case:
        return "", None
    full = default_stop(opts.trajectory)
    table = f"Table {table_number(opts.scenario, opts.trajectory)}"
    if abs(stop - full) > 1e-9:
        return (f"the thesis's values ({table}) are of the whole {full:g} s run: run without --stop-time to see them beside "
                "these"), None
    return table, thesis(opts.scenario, opts.trajectory, opts.controller)
