"""What running an FMU in its own process costs: per call, and on the whole loop.

Our controller FMU (FSI scenario, mixed design) is copied without its build record, so the
master treats it as foreign and hosts it in a worker process (master/engine/isolation/process.py). Printed:
the controller's microseconds per tick inside the master's FMI calls (set + doStep + get, the
round trip included) in process and isolated, and the loop's real-time factor both ways, with
no log. Also the start-up (worker process + instantiate). Target from issue 13: measure it, and
keep it opt-out (`--trust-fmus`).

Run: python benchmarks/isolation.py [stop]
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
import zipfile
from pathlib import Path

from tiltload.master.app.loop.fmus import build_all, is_foreign
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.execution import Execution


def foreign_copy(fmu: Path, dest: Path) -> Path:
    """The same FMU without resources/build_info.json: tiltload no longer recognizes it as its own."""
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as out:
        for item in src.infolist():
            if item.filename != "resources/build_info.json":
                out.writestr(item, src.read(item.filename))
    return dest


def timed(system, stop: float, trust: bool) -> tuple[float, float, float, dict]:
    ex = Execution(system, [loop_metrics()], isolate=None if trust else is_foreign, profile=True)
    t0 = time.perf_counter()
    ex.instantiate()
    start_up = time.perf_counter() - t0
    for inst in ex.instances.values():
        inst.fmi_seconds = 0.0
    t0 = time.perf_counter()
    ex.run(stop)
    wall = time.perf_counter() - t0
    ctrl = ex.instances["controller"].fmi_seconds
    metrics = ex.observers[0].table()
    ex.close()
    return start_up, wall, ctrl, metrics


def main() -> int:
    stop = float(sys.argv[1]) if len(sys.argv) > 1 else 20.0
    with tempfile.TemporaryDirectory() as tmp:
        fmus = Path(tmp) / "fmus"
        build_all(fmus)
        foreign = foreign_copy(fmus / "TiltloadController.fmu", Path(tmp) / "ForeignController.fmu")
        shutil.copy(foreign, fmus / "ForeignController.fmu")
        ticks = round(stop / 0.012)
        rows = {}
        for label, trust in (("in process", True), ("own process", False)):
            system = default_system(fmus, "fsi", 1, "mixed")
            system.instances[2].fmu = foreign
            best = min((timed(system, stop, trust) for _ in range(3)), key=lambda r: r[1])
            rows[label] = best
            start_up, wall, ctrl, _ = best
            print(f"controller {label:<12}: {1e6 * ctrl / ticks:6.1f} us per tick in its FMI calls, "
                  f"loop {stop / wall:5.0f}x real time, start-up {1e3 * start_up:6.0f} ms")
        (_, w_in, c_in, m_in), (_, w_out, c_out, m_out) = rows["in process"], rows["own process"]
        print(f"isolation costs {1e6 * (c_out - c_in) / ticks:.1f} us per controller step "
              f"({1e6 * (w_out - w_in) / ticks:.1f} us per tick on the loop, {100 * (w_out / w_in - 1):.0f} % of the loop's wall time)")
        same = all(m_in[k] == m_out[k] for k in m_in)
        print(f"metrics identical both ways: {same}")
        return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
