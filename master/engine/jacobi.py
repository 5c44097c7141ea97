"""What a Jacobi master does to a system, as connection delays tiltload's ordered master can run.

A fixed-step Jacobi master (libcosim, Ecos) steps every FMU from t_k, then passes every output to
the inputs it feeds: an input sees its source's output of the previous step. For a source whose
doStep(t_k) outputs hold the value at t_k (timing "sample": sensors, controller, scenario) that is
one tick late; for a source whose outputs are at t_k + h (timing "continuous": the plant) it is on
time, since the value at t_k is what the previous step produced. So the Jacobi master is the
ordered one with a delay of one tick on every connection out of a sample-timed instance, which is
how tiltload's master reproduces libcosim and Ecos on the same package (tests/engine/test_ssp.py).
"""

from __future__ import annotations

import dataclasses

from . import connections
from .system import Connection, System


def explicit(system: System, mds: dict, jacobi: bool = False) -> System:
    """The same system with every connection written out (auto_connect off), as SSP needs them; with jacobi,
    each connection out of a sample-timed instance carries one more tick of delay."""
    timing = {i.name: i.timing for i in system.instances}
    out = []
    for link in connections.resolve(system, mds):
        extra = 1 if jacobi and timing[link.source] == "sample" else 0
        out.append(Connection(f"{link.source}.{link.source_name}", f"{link.target}.{link.target_name}", link.delay + extra))
    return dataclasses.replace(system, connections=out, auto_connect=False)


def loop_delay(system: System, mds: dict, controller: str, plant: str, references: str) -> int:
    """Ticks between the plant's state and the command it receives in a feedback loop: the delay of the
    measurements into the controller (from any source but the reference generator) plus that of the
    commands into the plant. The three arguments are instance names."""
    links = connections.resolve(system, mds)
    measured = max((lk.delay for lk in links if lk.target == controller and lk.source != references), default=0)
    actuated = max((lk.delay for lk in links if lk.source == controller and lk.target == plant), default=0)
    return measured + actuated
