"""Processor-in-the-loop: an FMU's aarch64 binary served by tl_serve (master/engine/isolation/c/tl_serve.c, C99, no
Python), cross-built for aarch64 and run under qemu-user, as the remote instance of a run (docs/mil_sil_pil.md).

`served(fmu)` builds tl_serve for the platform (cached by its source and compiler), unpacks the FMU, writes a token
file, starts the server (under qemu-aarch64 on another machine type) and yields its address and token file: the
instance's `remote` and `token_file`. The master is the unchanged tiltload; only where the FMU runs differs.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import secrets
import shutil
import subprocess
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from ...engine.errors import DescriptionError

SOURCE = Path(__file__).resolve().parents[2] / "engine" / "isolation" / "c" / "tl_serve.c"
SYSROOT = {"aarch64-linux": "/usr/aarch64-linux-gnu"}
EMULATOR = {"aarch64-linux": "qemu-aarch64"}
START_TIMEOUT = 30.0  # s for the server to load the FMU and listen (qemu translates the binary on the way)


@dataclass(frozen=True)
class Served:
    address: str  # HOST:PORT
    token_file: Path
    platform: str


def _compiler(platform: str) -> str:
    from ....native_fmu.compile import find_compiler, toolchain

    cc = find_compiler(toolchain(platform))
    if cc is None:
        raise DescriptionError(f"tl_serve for {platform} needs {toolchain(platform).compiler} (Debian: apt-get install "
                               f"{toolchain(platform).package})")
    return cc


def build_server(platform: str = "aarch64-linux") -> Path:
    """tl_serve compiled for platform (aarch64-linux, x86_64-linux), cached by the source, the compiler and its flags."""
    from ....native_fmu.compile import compiler_identity
    from ....native_fmu.package import fmi_header_dir
    from ...engine.fmi.fmu_cache import cache_root

    cc = _compiler(platform)
    flags = ["-std=c99", "-pedantic", "-O2", "-Wall", "-Wextra", "-I", str(fmi_header_dir(2))]
    key = hashlib.sha256(SOURCE.read_bytes() + " ".join([platform, compiler_identity(cc), *flags[:-1]]).encode()).hexdigest()[:16]
    out = cache_root().parent / "tl_serve" / key / "tl_serve"
    if out.is_file():
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_suffix(f".{os.getpid()}")
    done = subprocess.run([cc, *flags, str(SOURCE), "-o", str(partial), "-ldl"], capture_output=True, text=True)
    if done.returncode != 0:
        raise DescriptionError(f"tl_serve does not compile for {platform}: {done.stderr.strip()[:2000]}")
    partial.replace(out)
    return out


def command(server: Path, platform: str) -> list[str]:
    """How to start the server here: itself on this machine's platform, else under qemu-user with its sysroot."""
    from ....native_fmu.compile import host_platform

    if platform == host_platform():
        return [str(server)]
    emulator = shutil.which(EMULATOR.get(platform, ""))
    if emulator is None:
        raise DescriptionError(f"running {platform} code here needs {EMULATOR.get(platform, 'an emulator')} (Debian: apt-get "
                               "install qemu-user)")
    return [emulator, "-L", SYSROOT[platform], str(server)]


@contextlib.contextmanager
def served(fmu: Path, platform: str = "aarch64-linux", sessions: int = 0):
    """The FMU's platform binary served by tl_serve (under qemu for another machine type) while the block runs."""
    server = build_server(platform)
    with tempfile.TemporaryDirectory(prefix="tl_serve_") as tmp:
        folder = Path(tmp) / "fmu"
        with zipfile.ZipFile(fmu) as z:
            z.extractall(folder)
        token = Path(tmp) / "token"
        token.write_text(secrets.token_hex(32))
        token.chmod(0o600)
        with open(Path(tmp) / "stderr", "wb") as err:
            proc = subprocess.Popen([*command(server, platform), "--fmu-dir", str(folder), "--token-file", str(token),
                                     "--bind", "127.0.0.1:0", "--sessions", str(sessions)], stdout=subprocess.PIPE, stderr=err, text=True)
        try:
            line = first_line(proc)
            if not line.startswith("listening on "):
                said = (Path(tmp) / "stderr").read_text(errors="replace").strip()
                raise DescriptionError(f"tl_serve for {platform} did not start: {said or line or 'no output'}")
            yield Served(line.removeprefix("listening on ").strip(), token, platform)
        finally:
            proc.kill()
            proc.wait()
            proc.stdout.close()


def first_line(proc: subprocess.Popen) -> str:
    import select

    ready, _, _ = select.select([proc.stdout], [], [], START_TIMEOUT)
    return proc.stdout.readline() if ready else ""
