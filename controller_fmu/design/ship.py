"""Regenerate the shipped designs (shipped.py): every one synthesized afresh on this machine, with its LMI point.

Run after a change to the model, the weights or the LMIs: python -m tiltload.controller_fmu.design.ship
"""

from __future__ import annotations

from pathlib import Path

from . import artifact
from .shipped import FOLDER, SHIPPED, TC, machine, path
from .synthesize import design


def write(folder: Path = FOLDER, progress=print) -> list[Path]:
    """Synthesize every shipped design afresh and write it (with its LMI point and the machine) into folder."""
    written = []
    for kind, loop_delay in SHIPPED:
        d = design(kind, TC, progress=progress, loop_delay=loop_delay)
        d.report["synthesis_machine"] = machine()
        written.append(artifact.save(d, Path(folder) / path(kind, loop_delay=loop_delay).name))
        progress(f"wrote {written[-1]}")
    return written


if __name__ == "__main__":
    write()
