"""The step time of one controller class as a native FMU (`tiltload wrap --native`) and as a pythonfmu FMU
(`tiltload wrap`), side by side in one process: FMPy steps each with the same inputs, and the commands they give are
compared. Prints µs per step (least of ROUNDS rounds) and the ratio.

    python benchmarks/wrap_native.py [docs/examples/hover_lqr_traced.py] [--steps 3000]
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from pathlib import Path

import numpy as np
from tiltload.master.app.cli import main

ROUNDS = 5


def stepper(fmu: Path, where: Path):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu), str(where)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    inputs = [v.name for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
    return slave, [vr[n] for n in inputs], [vr[n] for n in ("f_R", "f_L", "tau_R", "tau_L")]


def timed(fmu: Path, where: Path, values: np.ndarray, period: float) -> tuple[float, np.ndarray]:
    slave, ins, outs = stepper(fmu, where)
    best, out = float("inf"), []
    for _ in range(ROUNDS):
        out = []
        started = time.perf_counter()
        for k, row in enumerate(values):
            slave.setReal(ins, row.tolist())
            slave.doStep(k * period, period)
            out.append(slave.getReal(outs))
        best = min(best, (time.perf_counter() - started) / len(values))
        slave.reset()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
    slave.terminate()
    return best, np.array(out)


def machine() -> str:
    try:
        name = next(line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                    if line.startswith("model name"))
    except (OSError, StopIteration):
        name = platform.processor()
    return f"{platform.machine()} {name}".strip()


def run(source: Path, steps: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        assert main(["wrap", "--native", str(source), "--out", str(tmp / "native.fmu")]) == 0
        assert main(["wrap", str(source), "--out", str(tmp / "python.fmu")]) == 0
        n_in = len(stepper(tmp / "native.fmu", tmp / "probe")[1])
        rng = np.random.default_rng(1)
        values = 0.05 * rng.normal(size=(steps, n_in))
        native, a = timed(tmp / "native.fmu", tmp / "n", values, 0.012)
        python, b = timed(tmp / "python.fmu", tmp / "p", values, 0.012)
    print(f"{source.name} on {machine()} ({steps} steps, least of {ROUNDS} rounds)")
    print(f"  native C FMU (wrap --native): {native * 1e6:8.2f} µs a step (FMPy's call included)")
    print(f"  pythonfmu FMU (wrap):         {python * 1e6:8.2f} µs a step")
    print(f"  ratio: {python / native:.1f}x; largest difference of the commands {np.max(np.abs(a - b)):.3g}")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("source", nargs="?", type=Path, default=Path(__file__).parents[1] / "docs/examples/hover_lqr_traced.py")
    p.add_argument("--steps", type=int, default=3000)
    a = p.parse_args()
    run(a.source, a.steps)
