"""Signals at a run's edges: the one rule of when an output is logged, and where a run ends (docs/master.md, "Signals
at a run's edges"; docs/requirements.md links it).

The rule. A co-simulation FMU's outputs after doStep(t, h) belong to t + h (FMI's rule, FMPy's, every FMU's by
default: timing "continuous"); after initialization they belong to t = 0 and are logged once there. An instance the
system declares a sampled-data element (timing "sample": the thesis's sensors, controller and scenario) computes its
outputs at the start of its step, from its inputs at t_k, and holds them over [t_k, t_k + P): the outputs after its
doStep(t_k, P) belong to t_k, its initialization's outputs to no time (its step at t = 0 gives its sample there), and
the run ends with its closing sample, a step at the stop time T whose outputs belong to T. Either way each channel has
one sample per period from 0 to T, none twice.

A run ends at the stop time asked for: a whole number of ticks, or a shorter last communication step where every FMU
declares canHandleVariableCommunicationStepSize, else the first whole number of ticks after it, said before the run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

CONTINUOUS, SAMPLE = "continuous", "sample"
_GRID = 1e-9  # a stop time within this many ticks of a whole number of ticks is that number


def logs_initial(timing: str) -> bool:
    """Whether an instance's outputs after initialization are its sample at t = 0."""
    return timing != SAMPLE


def messages_before(timing: str, ticks_done: int, every: int) -> int:
    """How many samples an instance has had by the start of tick ticks_done (a run continued from a snapshot counts on
    from there): the one at t = 0 after initialization, if its kind has one, and one a step."""
    return int(logs_initial(timing)) - (-ticks_done // every)


@dataclass(frozen=True)
class StopPlan:
    """Where a run asked to stop at `asked` ends: after `ticks` ticks, at `end` s; the last one shortened (`shortened`)
    or the end rounded to the grid (`note` says so in one line; None when the end is the time asked for)."""

    asked: float
    ticks: int
    end: float
    shortened: bool
    note: str | None


def stop_plan(asked: float, tick: float, variable_step: dict[str, bool], start: float = 0.0) -> StopPlan:
    """The stop plan of a run on this tick from start (asked and the end are absolute times, as FMPy's stop time);
    variable_step: each instance's canHandleVariableCommunicationStepSize."""
    whole = (asked - start) / tick  # start 0: asked / tick, bit for bit
    n = round(whole)
    if abs(whole - n) <= _GRID * max(1.0, whole):
        return StopPlan(asked, n, asked, False, None)
    fixed = sorted(name for name, ok in variable_step.items() if not ok)
    if not fixed:
        return StopPlan(asked, math.ceil(whole), asked, True, None)
    n = math.ceil(whole)  # the first tick at or after the time asked: a window ending there is decided
    end = start + n * tick
    return StopPlan(asked, n, end, False,
                    f"stop time {asked:g} s is not a whole number of {tick * 1e3:g} ms ticks{f' after {start:g} s' if start else ''} "
                    f"and {', '.join(fixed)} cannot take a shorter last step: the run ends at {end:.9g} s ({n} ticks)")


def variable_steps(mds: dict) -> dict[str, bool]:
    """{instance: whether its FMU takes a communication step of another size} from the model descriptions."""
    out = {}
    for name, md in mds.items():
        cs = getattr(md, "coSimulation", None) or getattr(md, "scheduledExecution", None)
        out[name] = bool(getattr(cs, "canHandleVariableCommunicationStepSize", False)) if cs is not None else False
    return out


def propagation_order(system, links) -> list[str]:
    """The instances whose outputs are logged at t = 0, in the order their connected inputs are set after
    initialization: sources before their undelayed targets (Kahn's order, ties in the system's order; the rest of an
    algebraic loop in the system's order, once)."""
    names = [i.name for i in system.instances if logs_initial(i.timing)]
    wanted = set(names)
    before: dict[str, set[str]] = {n: set() for n in names}
    for link in links:
        if link.delay == 0 and link.target in wanted and link.source in wanted and link.source != link.target:
            before[link.target].add(link.source)
    order: list[str] = []
    while len(order) < len(names):
        ready = [n for n in names if n not in order and not (before[n] - set(order))]
        order.extend(ready[:1] or [next(n for n in names if n not in order)])
    return order


def algebraic_loop(system, links, mds: dict) -> list[str] | None:
    """An algebraic loop among the instances whose outputs are logged at t = 0: undelayed connections closing a cycle in
    which every FMU's output depends directly on the connected input before it, as its model description declares
    (ModelStructure Outputs' dependencies; an output that declares none is not taken for one). The cycle as
    "instance.variable" names, or None: then propagation_order sets every connected input from values already final."""
    wanted = {i.name for i in system.instances if logs_initial(i.timing)}
    after: dict[tuple[str, str], list[tuple[str, str]]] = {}
    for link in links:
        if link.delay == 0 and link.source in wanted and link.target in wanted:
            after.setdefault((link.source, link.source_name), []).append((link.target, link.target_name))
    for name in wanted:
        for unknown in getattr(mds[name], "outputs", None) or ():
            for dep in unknown.dependencies or ():
                if dep.causality == "input":
                    after.setdefault((name, dep.name), []).append((name, unknown.variable.name))
    done: set = set()
    for start in list(after):  # depth first, without recursion (a system may chain many variables)
        if start in done:
            continue
        path, on_path, stack = [start], {start}, [iter(after.get(start, ()))]
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                node = path.pop()
                on_path.discard(node)
                done.add(node)
                stack.pop()
                continue
            if nxt in on_path:
                return [f"{i}.{v}" for i, v in path[path.index(nxt):] + [nxt]]
            if nxt not in done:
                path.append(nxt)
                on_path.add(nxt)
                stack.append(iter(after.get(nxt, ())))
    return None
