"""A restart keeps the tick loop's plan (its tables, buffers and function pointers) and gives every step a fresh
instantiation gives, bit for bit: with a delay line, faults the kernel applies (their delay rings and draws), faults
Python applies, a new fault schedule or none, and new parameters."""

from __future__ import annotations

import numpy as np
from tiltload.master.app.loop.thesis import default_system
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.faults.parse import parse
from tiltload.master.engine.observers import Observer

# kernel-applied (a delay ring, a draw), Python-applied (an input no connection drives), on the delayed connection
FIRST = [{"action": "delay", "target": "sensors.meas_d_BL_x", "value": 2, "start": 0.1},
         {"action": "noise", "target": "scenario.x_ref", "value": 0.05, "seed": 3, "start": 0.2, "end": 0.5},
         {"action": "override", "target": "plant.servo_R_stuck", "value": True, "start": 0.3, "end": 0.5},
         {"action": "bias", "target": "plant.f_R", "value": 0.3, "start": 0.1, "end": 0.4}]
SECOND = [{"action": "stale", "target": "sensors.meas_d_BL_x", "value": 4, "start": 0.15, "end": 0.6},
          {"action": "noise", "target": "scenario.x_ref", "value": 0.02, "seed": 11, "start": 0.1},
          {"action": "hold", "target": "plant.f_L", "start": 0.25, "end": 0.45}]


class Steps(Observer):
    """Every step's outputs (copied) and every fault event, as delivered."""

    def __init__(self) -> None:
        self.rows: dict[tuple[str, str], list[np.ndarray]] = {}
        self.records: list[np.ndarray] = []
        self.events: list[tuple] = []

    def on_batch(self, execution, batch) -> None:
        self.records.append(np.column_stack([batch.instance, batch.tick, batch.time]).copy())
        for name, by_type in batch.rows.items():
            for typ, rows in by_type.items():
                self.rows.setdefault((name, typ), []).append(rows.copy())
        self.events += [(p, t, f.action, what) for p, t, f, what in batch.events]

    def same_as(self, other: Steps) -> bool:
        def joined(parts):
            return np.concatenate(parts).tobytes()  # bits, NaN included
        return (self.rows.keys() == other.rows.keys() and joined(self.records) == joined(other.records)
                and all(joined(self.rows[k]) == joined(other.rows[k]) for k in self.rows) and self.events == other.events)


def _system(fmus, seed: int, mass: float, faults: list):
    system = default_system(fmus, "zse", 1, "mixed", seed=seed, delay=True)  # delay: a delay line in the plan
    system.instance("plant").parameters["m_L"] = mass
    system.faults = parse(faults) if faults else []
    return system


def _fresh(fmus, seed: int, mass: float, faults: list, stop: float) -> Steps:
    steps = Steps()
    ex = Execution(_system(fmus, seed, mass, faults), [steps])
    try:
        ex.instantiate()
        ex.run(stop)
    finally:
        ex.close()
    return steps


def test_a_restart_keeps_the_plan_and_repeats_a_fresh_run_bit_for_bit(fmus):
    stop = 0.7
    ex = Execution(_system(fmus, 2, 0.1, FIRST), [Steps()])
    runs = []
    try:
        ex.instantiate()
        plan = ex.loop
        ex.run(stop)
        for seed, mass, faults in ((5, 0.25, SECOND), (5, 0.25, []), (2, 0.1, FIRST)):
            system = _system(fmus, seed, mass, faults)
            runs.append(Steps())
            ex.restart({i.name: dict(i.parameters) for i in system.instances}, [runs[-1]], system.faults)
            assert ex.loop is plan  # kept, not rebuilt
            ex.run(stop)
    finally:
        ex.close()
    assert all(r.events for r in (runs[0], runs[2])) and not runs[1].events
    for run, (seed, mass, faults) in zip(runs, ((5, 0.25, SECOND), (5, 0.25, []), (2, 0.1, FIRST))):
        assert run.same_as(_fresh(fmus, seed, mass, faults, stop))

