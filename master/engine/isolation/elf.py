"""The processor an FMU's Linux library is built for, read from its ELF header, and this machine's, in the same names:
a server refuses an FMU built for another processor with a line rather than a loader error."""

from __future__ import annotations

import platform
import zipfile
from pathlib import Path

from ..fmi.binaries import library_member

_ELF_MACHINES = {3: "x86", 40: "arm", 62: "x86_64", 183: "aarch64", 243: "riscv64"}
_THIS_MACHINE = {"amd64": "x86_64", "arm64": "aarch64", "i686": "x86", "i386": "x86"}


def library_machine(fmu: Path, model_identifier: str) -> str | None:
    """The processor of the Linux library this machine would load from the FMU (binaries.py; failing that, of any it
    holds), from its ELF header; None if it has none or it cannot be read. A library for another processor is then
    refused with a line, not a loader error."""
    try:
        with zipfile.ZipFile(fmu) as z:
            member = library_member(z.namelist(), model_identifier)
            if member is None:
                return None
            with z.open(member) as f:
                header = f.read(20)
    except (OSError, zipfile.BadZipFile):
        return None
    if header[:4] != b"\x7fELF" or len(header) < 20:
        return None
    return _ELF_MACHINES.get(int.from_bytes(header[18:20], "little" if header[5] == 1 else "big"), "another processor")


def this_machine() -> str:
    machine = platform.machine().lower()
    return _THIS_MACHINE.get(machine, machine)
