"""A tiltload run that reports its simulated time, for the kill tests: python kill_target.py FMU_DIR LOG TIME_FILE.

The run is the ZSE loop on trajectory 1; after every tick the simulated time is written (8 bytes)
into TIME_FILE, so a test that kills this process knows how far the simulation had got.
"""

import os
import struct
import sys
import time
from pathlib import Path

from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.observers import Observer
from tiltload.master.engine.run import run_system, terminate_like_interrupt


class Reporter(Observer):
    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_CREAT)

    def on_tick(self, k, t) -> None:
        os.pwrite(self.fd, struct.pack("d", t), 0)
        time.sleep(0.0005)  # 40 s run in ~0.6 s: slowed, so a signal sent once t is reached lands mid-run even when busy


if __name__ == "__main__":
    terminate_like_interrupt()
    fmus, log, clock = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
    result = run_system(default_system(fmus, "zse", 1, "mixed"), 40.0, log, loop_metrics(),
                        progress=False, observers_extra=[Reporter(clock)])
    print(result.error or "done", flush=True)
    sys.exit(128 + result.signal if result.signal else (1 if result.error else 0))
