"""A controller class's step time by route, in the closed loop: the native C FMU (`wrap --native`), the pythonfmu FMU
(`wrap`) in tiltload's process, and the pythonfmu FMU in a worker process of its own (tiltload's default for an FMU it
did not compile). The time is the controller's FMI calls per tick (set, doStep, get; the round trip to the worker
included), measured by the master (Execution's profile), over the same loop (fsi, trajectory 1, no log), best of
--repeat runs. The machine's load average is printed with the figures: on a shared machine they are upper bounds.

    python benchmarks/controller_routes.py [docs/examples/hover_lqr_traced.py] [--stop 10] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from tiltload.master.app.cli import main
from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.fmi.pythonfmu_guard import pin
from timing import machine


def controller_seconds(fmus: Path, fmu: Path, stop: float, isolated: bool) -> tuple[float, dict]:
    """The controller's FMI seconds over one run, and the run's metrics."""
    system = default_system(fmus, "fsi", 1, None, 1, fmu)
    ex = Execution(system, [loop_metrics()], isolate=(lambda f, md: Path(f) == fmu) if isolated else None, profile=True)
    ex.instantiate()
    for instance in ex.instances.values():
        instance.fmi_seconds = 0.0
    ex.run(stop)
    seconds, metrics = ex.instances["controller"].fmi_seconds, ex.observers[0].table()
    ex.close()
    return seconds, metrics


def run(source: Path, stop: float, repeat: int) -> None:
    fmus = build_all(Path(__file__).parents[1] / "fmus", progress=lambda *_: None)[0].path.parent
    ticks = round(stop / 0.012)
    with tempfile.TemporaryDirectory() as tmp:
        native, python = Path(tmp) / "native.fmu", Path(tmp) / "python.fmu"
        assert main(["wrap", "--native", str(source), "--out", str(native)]) == 0
        assert main(["wrap", str(source), "--out", str(python)]) == 0
        pin(python)  # pythonfmu's runtime stays loaded once per process, as tiltload run keeps it
        rows = {}
        for label, fmu, isolated in (("native C FMU, in process", native, False),
                                     ("pythonfmu FMU, in process", python, False),
                                     ("pythonfmu FMU, own process", python, True)):
            best = min(controller_seconds(fmus, fmu, stop, isolated) for _ in range(repeat))
            rows[label] = best
        load = os.getloadavg()
        print(f"{source.name} on {machine()} at {time.strftime('%H:%M:%S')} "
              f"({'a loaded machine: upper bounds' if load[0] > 1 else 'idle'})")
        print(f"fsi, trajectory 1, {stop:g} s ({ticks} ticks), best of {repeat}; the controller's FMI calls per tick:")
        for label, (seconds, _) in rows.items():
            print(f"  {label:<28} {1e6 * seconds / ticks:9.1f} us")
        first = next(iter(rows.values()))[1]
        same = [label for label, (_, m) in rows.items() if all(abs(m[k] - first[k]) <= 1e-9 * abs(first[k]) for k in first)]
        print(f"metrics within 1e-9 of the native run's: {', '.join(same)}")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("source", nargs="?", type=Path, default=Path(__file__).parents[1] / "docs/examples/hover_lqr_traced.py")
    p.add_argument("--stop", type=float, default=10.0)
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args()
    run(a.source, a.stop, a.repeat)
