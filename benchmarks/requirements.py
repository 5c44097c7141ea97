"""What requirements cost: online in the loop, offline on a log, and the windowed min against a slice per sample.

1. Ten requirements (the first ten of docs/requirements/thesis.yaml) monitored online in a 40 s FSI run (trajectory 1,
   mixed design) with the full log (every step, the 3D scene), against the same run without them: wall time of the
   run (ex.run and the observers' finish: the verdicts, the /requirements channel and the log's close), best and median of
   --repeat pairs taken in turn, wall and CPU. Target: a ratio <= 1.05.
2. The offline check of that run's 40 s log: reading the log's channels, then the verdicts, per requirement.
3. A 10 s `always` window at 10,000 samples (the 12 ms tick: 834 samples a window): sliding_min (the monitor's:
   scipy's filter in C), Lemire's monotonic deque (a Python loop), and the naive slice per sample (rtamt's way), side by side.

Run: python benchmarks/requirements.py [--repeat 9]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from tiltload.master.app.loop.fmus import build_all
from tiltload.master.app.loop.scene import scene_channels
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.log.logger import McapLogger
from tiltload.master.engine.requirement.check import build_trace, check_trace
from tiltload.master.engine.requirement.files import load
from tiltload.master.engine.requirement.observer import RequirementObserver
from tiltload.master.engine.requirement.stl.windows import sliding_min, sliding_min_deque
from timing import best, machine, timed

ROOT = Path(__file__).resolve().parents[1]
STOP = 40.0


class TimedObserver(RequirementObserver):
    """The observer with its own time measured: per batch, and at the end (the verdicts and the channel)."""

    def start(self, execution) -> None:
        self.spent = {"start": 0.0, "batches": 0.0, "end": 0.0}
        t0 = time.perf_counter()
        super().start(execution)
        self.spent["start"] += time.perf_counter() - t0

    def on_batch(self, execution, batch) -> None:
        t0 = time.perf_counter()
        super().on_batch(execution, batch)
        self.spent["batches"] += time.perf_counter() - t0

    def _to_log(self, logger, error) -> None:
        t0 = time.perf_counter()
        super()._to_log(logger, error)
        self.spent["end"] += time.perf_counter() - t0


def online(fmus: Path, reqs, repeat: int, out: Path):
    system = default_system(fmus, "fsi", 1, "mixed", 1)
    runs = {"without": [], "with 10 requirements": []}
    own: list[dict] = []
    for k in range(repeat):
        for case in (list(runs) if k % 2 == 0 else list(runs)[::-1]):
            logger = McapLogger(out / f"{k}_{len(runs[case])}.mcap", metadata={"stop_time": STOP}, derived=scene_channels("plant"))
            observers = [logger, loop_metrics()]
            if case != "without":
                observers.append(TimedObserver(reqs))
            runs[case].append(timed(system, STOP, observers, profile=False))
            if case != "without":
                own.append(observers[-1].spent)
    base = best(runs["without"])
    med = {case: (statistics.median(r.wall for r in rs), statistics.median(r.cpu for r in rs)) for case, rs in runs.items()}
    pairs = list(zip(runs["without"], runs["with 10 requirements"]))
    print(f"1. online, {STOP:g} s FSI run with the full log, {repeat} pairs taken in turn (A B, B A, ...):")
    for case, rs in runs.items():
        b = best(rs)
        print(f"   {case:<22} best {b.wall * 1e3:7.1f} ms  ratio {b.wall / base.wall:.3f} (cpu {b.cpu * 1e3:6.1f} ms, ratio "
              f"{b.cpu / base.cpu:.3f});  median {med[case][0] * 1e3:7.1f} ms  ratio {med[case][0] / med['without'][0]:.3f} "
              f"(cpu {med[case][1] * 1e3:6.1f} ms, ratio {med[case][1] / med['without'][1]:.3f})")
    print(f"   median of the {len(pairs)} pairs' ratios: wall {statistics.median(w.wall / a.wall for a, w in pairs):.3f}, "
          f"cpu {statistics.median(w.cpu / a.cpu for a, w in pairs):.3f}")
    least = min(own, key=lambda s: sum(s.values()))
    total = sum(least.values())
    print(f"   the observer's own time (least of {repeat}): {total * 1e3:.1f} ms = {total / base.wall:.3f} of the run without "
          f"(start {least['start'] * 1e3:.1f}, batches {least['batches'] * 1e3:.1f}, verdicts and channel {least['end'] * 1e3:.1f} ms)")
    return out / "0_0.mcap"


def offline(log: Path, reqs, repeat: int) -> None:
    topics = sorted({f"/{n.split('.')[0]}" for r in reqs for n in r.signals})
    reads, verdicts = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        columns, _ = log_reader.read_columns(log, topics)
        series = {topic.lstrip("/"): c for topic, c in columns.items()}
        t1 = time.perf_counter()
        check_trace(reqs, lambda r: build_trace(series, r.signals))
        t2 = time.perf_counter()
        reads.append(t1 - t0)
        verdicts.append(t2 - t1)
    n = len(reqs)
    span = log_reader.check(log).intact_until
    print(f"2. offline check of the {STOP:g} s log ({span:g} s, {len(topics)} channels read), best of {repeat}:")
    print(f"   reading the channels {min(reads) * 1e3:8.1f} ms;  the verdicts {min(verdicts) * 1e3:7.2f} ms "
          f"= {min(verdicts) / n * 1e3:.2f} ms per requirement;  all {(min(reads) + min(verdicts)) / n * 1e3:.1f} ms per requirement")


def windows(repeat: int) -> None:
    n, w = 10_000, int(round(10 / 0.012)) + 1
    x = np.random.default_rng(1).normal(size=n)
    naive = lambda: np.array([min(x[i:i + w]) for i in range(n)])  # noqa: E731  (the builtin min over a slice, as rtamt)
    numpy_slices = lambda: np.array([x[i:i + w].min() for i in range(n)])  # noqa: E731
    cases = {"sliding_min (scipy's filter, C)": lambda: sliding_min(x, 0, w - 1),
             "Lemire's deque (Python loop)": lambda: sliding_min_deque(x, 0, w - 1),
             "slice per sample, numpy min": numpy_slices,
             "slice per sample, builtin min": naive}
    ref = sliding_min(x, 0, w - 1)
    print(f"3. always[0:10] at {n} samples, {w} a window (12 ms tick), best of {repeat}:")
    base = None
    for name, fn in cases.items():
        times = []
        for _ in range(repeat if "builtin" not in name else max(1, repeat // 3)):
            t0 = time.perf_counter()
            got = fn()
            times.append(time.perf_counter() - t0)
        assert np.array_equal(got, ref), name
        base = base or min(times)
        print(f"   {name:<32} {min(times) * 1e3:9.2f} ms   x{min(times) / base:7.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(allow_abbrev=False)
    ap.add_argument("--repeat", type=int, default=9)
    args = ap.parse_args()
    print(machine())
    build_all(ROOT / "fmus", progress=lambda *_: None)
    reqs = load(ROOT / "docs" / "requirements" / "thesis.yaml")[:10]
    with tempfile.TemporaryDirectory() as tmp:
        log = online(ROOT / "fmus", reqs, args.repeat, Path(tmp))
        offline(log, reqs, args.repeat)
    windows(args.repeat)


if __name__ == "__main__":
    main()
