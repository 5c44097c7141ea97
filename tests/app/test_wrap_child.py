"""wrap's child process (master/app/wrap/sandbox.py) builds the same FMU whatever the calling process holds: after a
pythonfmu FMU was pinned here (its resources, which bundle a pythonfmu without binaries, on this process's sys.path),
the next pythonfmu FMU still carries its model's binaries."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[2] / "docs" / "examples"

PIN_THEN_WRAP = """
import sys
from pathlib import Path
from tiltload.master.app.cli import main
from tiltload.master.engine.fmi.pythonfmu_guard import exit_now, pin
first, second = Path(sys.argv[1]), Path(sys.argv[2])
assert main(["wrap", sys.argv[3], "--out", str(first)]) == 0
pin(first)
assert main(["wrap", sys.argv[4], "--out", str(second)]) == 0
exit_now(0)
"""


def test_a_wrap_after_a_pinned_pythonfmu_fmu_carries_its_binaries(tmp_path):
    first, second = tmp_path / "first.fmu", tmp_path / "second.fmu"
    done = subprocess.run([sys.executable, "-c", PIN_THEN_WRAP, str(first), str(second), str(EXAMPLES / "hover_lqr.py"),
                           str(EXAMPLES / "hover_lqr_traced.py")], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    with zipfile.ZipFile(second) as z:
        names = z.namelist()
    assert "binaries/linux64/HoverLQRTraced.so" in names, [n for n in names if n.startswith("binaries")]
