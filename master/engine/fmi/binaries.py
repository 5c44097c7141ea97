"""Which of an FMU's binaries this machine loads.

FMI 2.0 names binary folders for x86 only (linux64, win64, darwin64); for other processors FMI 2.0.4
advises <arch>-<os>, which tiltload's builder writes (binaries/aarch64-linux, native_fmu/compile.TOOLCHAINS).
FMPy loads binaries/linux64 on every 64-bit Linux, so on an aarch64 machine an FMU built for several
platforms would hand it the x86-64 library: the aarch64-linux folder comes first there.
"""

from __future__ import annotations

from pathlib import Path


def folders(machine: str | None = None) -> tuple[str, ...]:
    """The binaries/ folders this machine loads, best first; machine (FMPy's platform tuple, e.g. aarch64-linux)
    asks as another 64-bit Linux would."""
    from fmpy import platform, platform_tuple

    if (machine or platform_tuple) == "aarch64-linux":
        return ("aarch64-linux", "linux64")  # linux64 last: a board's copy made the FMI 2.0 way
    return (platform, platform_tuple) if machine is None else ("linux64", "x86_64-linux")  # FMI 2.0's name, then 3.0's


def library_path(unzipped: Path | str, model_identifier: str) -> str | None:
    """The library of an unpacked FMU this machine loads; None: none of its folders has one (FMPy then says so)."""
    from fmpy import sharedLibraryExtension

    for folder in folders():
        path = Path(unzipped) / "binaries" / folder / f"{model_identifier}{sharedLibraryExtension}"
        if path.is_file():
            return str(path.resolve())
    return None


def library_member(names: list[str], model_identifier: str, machine: str | None = None) -> str | None:
    """The Linux library among an FMU's zip members (names) this machine (or machine, as in folders) would load,
    else any Linux library of the model's (to say what it is built for)."""
    wanted = [f"binaries/{folder}/{model_identifier}.so" for folder in folders(machine)]
    found = next((n for n in wanted if n in names), None)
    return found or next((n for n in names if n.startswith("binaries/") and n.endswith(f"/{model_identifier}.so")), None)
