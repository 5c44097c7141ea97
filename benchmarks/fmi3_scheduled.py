"""The twelve reproduction cases with the Scheduled Execution controller, beside the co-simulation clocked one.

For each case (full length, seed 1): our master with TiltloadControllerClocked, our master with TiltloadControllerSE
(scheduled by the C tick loop, master/engine/native/tl_loop.c; benchmarks/fmi3.py runs the Python path too), and the
C host tests/support/hosts/fmi3_se_host.c (written from the standard) with TiltloadControllerSE. Printed: whether
the SE runs' metrics (master) and plant trajectory (C host, every tick, all 20 states) are the same bits as the
clocked run's, the wall time of each, and the C host's CPU time. Exit 1 if any case differs.

Run: python benchmarks/fmi3_scheduled.py [FMU3_FOLDER]   (default: the FMI 3.0 FMUs built into a temporary folder)
"""

from __future__ import annotations

import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the plan writer and the host of the test suite
from support import HOSTS  # noqa: E402
from support.fmi3_plan import host_plan  # noqa: E402
from tiltload.master.app.loop.fmus import build_all, build_many, fmu_folder, scheduled_recipes  # noqa: E402
from tiltload.master.app.loop.thesis import default_stop, default_system, loop_metrics  # noqa: E402
from tiltload.master.app.regression.reproduce import CASES, SEED, case_name  # noqa: E402
from tiltload.master.engine.execution import Execution  # noqa: E402
from tiltload.master.engine.observers import Observer  # noqa: E402
from tiltload.native_fmu.package import fmi_header_dir  # noqa: E402
from tiltload.plant_fmu.interface import STATE_NAMES  # noqa: E402

TICK = 0.012


def master_run(system, ticks: int):
    """Our master: (metrics, the plant's states at every tick, wall s)."""
    metrics = loop_metrics()
    rows = []

    class Plant(Observer):
        def on_step(self, instance, t) -> None:
            if instance.name == "plant":
                rows.append(instance.values["Real"].copy())

    ex = Execution(system, [metrics, Plant()])
    try:
        ex.instantiate()
        names = [v.name for v in ex.instances["plant"].outputs["Real"]]
        started = time.perf_counter()
        ex.run(ticks * TICK)
        wall = time.perf_counter() - started
    finally:
        ex.close()
    return metrics.table(), np.array(rows)[:, [names.index(n) for n in STATE_NAMES]], wall


def host_run(host: Path, system, se: Path, ticks: int, folder: Path):
    plan = host_plan(system, folder, ticks, [("plant", n) for n in STATE_NAMES], scheduled={"controller": se})
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    proc = subprocess.run([str(host), str(plan)], capture_output=True, text=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"the C host failed: {proc.stderr[-500:]}")
    values = [float.fromhex(line.split()[3]) for line in proc.stdout.splitlines() if " plant " in line]
    return np.array(values).reshape(ticks, len(STATE_NAMES)), wall, after.ru_utime - before.ru_utime


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        folder = Path(sys.argv[1]) if len(sys.argv) > 1 else fmu_folder(tmp / "fmus", 3)
        say = lambda m: print(f"  {m}", file=sys.stderr)  # noqa: E731
        build_all(folder, progress=say, fmi_version=3)
        build_all(folder, progress=say, fmi_version=3, clocked=True)
        build_many(scheduled_recipes(("load",)), folder, progress=say, fmi_version=3)
        se = folder / "TiltloadControllerSE.fmu"
        host = tmp / "fmi3_se_host"
        subprocess.run(["cc", "-std=c11", "-O2", f"-I{fmi_header_dir(3)}", str(HOSTS / "fmi3_se_host.c"), "-o", str(host),
                        "-ldl", "-lm"], check=True)
        print(f"machine: {platform.node()} {platform.machine()} ({sys.version.split()[0]}); seed {SEED}, full length")
        print(f"{'case':>16} {'ticks':>6} {'master SE metrics':>18} {'C host SE states':>17} {'wall s: clocked':>16} "
              f"{'SE':>6} {'C host':>7} {'C host cpu s':>13}")
        differ = 0
        for i, case in enumerate(CASES):
            ticks = round(default_stop(case[1]) / TICK)
            clocked = default_system(folder, *case, SEED, fmi=3, clocked=True)
            scheduled = default_system(folder, *case, SEED, fmi=3, clocked=True)
            scheduled.instance("controller").fmu = se
            m_c, states_c, wall_c = master_run(clocked, ticks)
            m_s, _, wall_s = master_run(scheduled, ticks)
            (tmp / str(i)).mkdir()
            states_h, wall_h, cpu_h = host_run(host, clocked, se, ticks, tmp / str(i))
            same_m, same_h = m_s == m_c, np.array_equal(states_h, states_c)
            differ += not (same_m and same_h)
            print(f"{case_name(*case):>16} {ticks:6d} {'same bits' if same_m else 'DIFFER':>18} "
                  f"{'same bits' if same_h else 'DIFFER':>17} {wall_c:16.2f} {wall_s:6.2f} {wall_h:7.2f} {cpu_h:13.2f}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
