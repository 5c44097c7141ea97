"""The engine's C kernel: the tick loop (tl_loop.c), the log's record layout (tl_mcap.c) and the noise fault's draws
(tl_draw.c, linked with numpy's own C random library), compiled once with the system C compiler, loaded with ctypes.

A library is built into $TILTLOAD_CACHE/kernels/<digest of sources, compiler and flags>/ (else
$XDG_CACHE_HOME/tiltload or ~/.cache/tiltload; a temporary folder if none is writable), so a
second process loads it in microseconds. compiled() builds any such library (the application's
scene encoder is one). The structures below mirror tl_loop.h field by field; library() checks them against the
layout the compiled kernel reports (layout.py), and the codes they carry are codes.py's, read from tl_codes.h.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
import threading
from functools import cache
from pathlib import Path

from . import layout
from .codes import Dimension, FaultAction

HERE = Path(__file__).parent
SOURCES = (HERE / "tl_loop.c", HERE / "tl_mcap.c", HERE / "tl_layout.c", HERE / "tl_loop.h", HERE / "tl_mcap.h", HERE / "tl_draw.h",
           HERE / "tl_codes.h", HERE / "tl_link.h")
DRAWS = (HERE / "tl_draw.c",)
ENTROPY_WORDS = int(Dimension.ENTROPY_WORDS)
# The floating-point results that depend on these flags: t_k = k * tick (one product, exact in IEEE double) and the
# faults' arithmetic, kept operation for operation as Python's by -ffp-contract=off.
CFLAGS = ("-std=c11", "-O2", "-fPIC", "-shared", "-fvisibility=hidden", "-ffp-contract=off", "-Wall", "-Wextra")
TYPES = int(Dimension.TYPES)

STEP_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int, ctypes.c_double, ctypes.c_double)
HOOK_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_double)


class KernelError(RuntimeError):
    """The C compiler is missing or failed on a kernel (a C compiler is required, as for the FMUs)."""


class Group(ctypes.Structure):
    _fields_ = [("source", ctypes.c_int), ("type", ctypes.c_int), ("source_type", ctypes.c_int), ("delay", ctypes.c_int),
                ("n", ctypes.c_int),
                ("src_index", ctypes.c_void_p), ("dst_vrs", ctypes.c_void_p), ("values", ctypes.c_void_p)]


class Fault(ctypes.Structure):
    _fields_ = [("instance", ctypes.c_int), ("side", ctypes.c_int), ("action", ctypes.c_int), ("type", ctypes.c_int),
                ("array", ctypes.c_void_p), ("index", ctypes.c_int), ("value", ctypes.c_double), ("high", ctypes.c_double),
                ("start", ctypes.c_double), ("end", ctypes.c_double), ("fault", ctypes.c_int), ("reports", ctypes.c_int),
                ("holding", ctypes.c_int), ("held", ctypes.c_double), ("n_entropy", ctypes.c_int),
                ("entropy", ctypes.c_uint32 * ENTROPY_WORDS), ("history", ctypes.c_void_p),
                ("history_capacity", ctypes.c_int64), ("history_count", ctypes.c_int64), ("history_next", ctypes.c_int64)]


# the faults the loop can apply, by the schedule's names (delay and stale read the history alike)
FAULT_ACTIONS = {action.name.lower(): action for action in FaultAction} | {"stale": FaultAction.DELAY}


class Part(ctypes.Structure):
    _fields_ = [("group", ctypes.c_int), ("kind", ctypes.c_int), ("n", ctypes.c_int), ("vrs", ctypes.c_void_p),
                ("index", ctypes.c_void_p), ("whole", ctypes.c_int), ("buffer", ctypes.c_void_p), ("applied", ctypes.c_void_p),
                ("has_applied", ctypes.c_int)]


class Read(ctypes.Structure):
    _fields_ = [("type", ctypes.c_int), ("clock", ctypes.c_int), ("n", ctypes.c_int), ("vrs", ctypes.c_void_p),
                ("index", ctypes.c_void_p), ("whole", ctypes.c_int), ("buffer", ctypes.c_void_p)]


class Clocks(ctypes.Structure):
    _fields_ = [("enter_event_mode", ctypes.c_void_p), ("enter_step_mode", ctypes.c_void_p), ("set_clock", ctypes.c_void_p),
                ("update_discrete_states", ctypes.c_void_p), ("n_clocks", ctypes.c_int), ("clock_vrs", ctypes.c_void_p),
                ("interval", ctypes.c_void_p), ("shift", ctypes.c_void_p), ("n_parts", ctypes.c_int),
                ("parts", ctypes.POINTER(Part)), ("n_reads", ctypes.c_int), ("reads", ctypes.POINTER(Read)),
                ("read_first", ctypes.c_void_p), ("max_iterations", ctypes.c_int), ("in_event", ctypes.c_int),
                ("event_asked", ctypes.c_int), ("next_event_defined", ctypes.c_int), ("next_event", ctypes.c_double),
                ("due", ctypes.c_void_p), ("due_vrs", ctypes.c_void_p), ("due_on", ctypes.c_void_p),
                ("activation_capacity", ctypes.c_int64), ("activations", ctypes.c_int64),
                ("activation_clock", ctypes.c_void_p), ("activation_tick", ctypes.c_void_p),
                ("activate", ctypes.c_void_p), ("order", ctypes.c_void_p), ("lock_depth", ctypes.c_void_p)]


class Link(ctypes.Structure):
    _fields_ = [("base", ctypes.c_void_p), ("size", ctypes.c_int64), ("in_offset", ctypes.c_void_p),
                ("out_offset", ctypes.c_int64), ("seq", ctypes.c_uint32), ("hung_up_fd", ctypes.c_int), ("signal_fd", ctypes.c_int),
                ("timeout_ns", ctypes.c_int64), ("spin_ns", ctypes.c_int64), ("usual_wait_ns", ctypes.c_int64),
                ("n_clocks", ctypes.c_int)]


class Instance(ctypes.Structure):
    _fields_ = [("component", ctypes.c_void_p), ("do_step", ctypes.c_void_p), ("set", ctypes.c_void_p * TYPES),
                ("get", ctypes.c_void_p * TYPES), ("boolean_status", ctypes.c_void_p), ("real_status", ctypes.c_void_p),
                ("do_step3", ctypes.c_void_p), ("set3", ctypes.c_void_p * TYPES),
                ("get3", ctypes.c_void_p * TYPES), ("every", ctypes.c_int), ("continuous", ctypes.c_int),
                ("by_callback", ctypes.c_int), ("fmi3", ctypes.c_int), ("booleans", ctypes.c_void_p),
                ("hook_inputs", ctypes.c_int), ("hook_outputs", ctypes.c_int),
                ("n_out", ctypes.c_int * TYPES), ("out_vrs", ctypes.c_void_p * TYPES), ("out", ctypes.c_void_p * TYPES),
                ("history", ctypes.c_void_p * TYPES), ("n_groups", ctypes.c_int), ("groups", ctypes.POINTER(Group)),
                ("record", ctypes.c_void_p * TYPES), ("seconds", ctypes.c_double), ("histogram", ctypes.c_void_p),
                ("fastest_ns", ctypes.c_int64), ("slowest_ns", ctypes.c_int64), ("host_ns", ctypes.c_int64),
                ("clocks", ctypes.POINTER(Clocks)), ("link", ctypes.POINTER(Link))]


class Plan(ctypes.Structure):
    _fields_ = [("n_instances", ctypes.c_int), ("instances", ctypes.POINTER(Instance)), ("tick", ctypes.c_double),
                ("start_time", ctypes.c_double), ("ticks_done", ctypes.c_int64), ("slots", ctypes.c_int), ("step_callback", STEP_CALLBACK),
                ("hook_callback", HOOK_CALLBACK), ("profile", ctypes.c_int), ("tick_histogram", ctypes.c_void_p),
                ("tick_ns", ctypes.c_int64), ("fastest_tick_ns", ctypes.c_int64), ("slowest_tick_ns", ctypes.c_int64),
                ("record_capacity", ctypes.c_int64),
                ("records", ctypes.c_int64), ("record_instance", ctypes.c_void_p), ("record_tick", ctypes.c_void_p),
                ("record_time", ctypes.c_void_p),
                ("record_row", ctypes.c_void_p), ("rows", ctypes.c_void_p), ("error_kind", ctypes.c_int),
                ("error_instance", ctypes.c_int), ("error_status", ctypes.c_int), ("error_group", ctypes.c_int),
                ("error_type", ctypes.c_int), ("error_time", ctypes.c_double), ("realtime_factor", ctypes.c_double),
                ("realtime_start_ns", ctypes.c_int64), ("realtime_first_tick", ctypes.c_int64),
                ("n_faults", ctypes.c_int), ("faults", ctypes.POINTER(Fault)), ("fault_on", ctypes.c_void_p),
                ("event_capacity", ctypes.c_int64), ("events", ctypes.c_int64), ("event_record", ctypes.c_void_p),
                ("event_fault", ctypes.c_void_p), ("event_start", ctypes.c_void_p), ("event_time", ctypes.c_void_p),
                ("lateness", ctypes.c_void_p), ("overrun", ctypes.c_void_p), ("stop_time", ctypes.c_double),
                ("closing", ctypes.c_int), ("ended_instance", ctypes.c_int), ("ended_time", ctypes.c_double),
                ("ends_allowed", ctypes.c_int)]


# the structs tl_loop.h shares, by their C names (layout.check compares each with the library's layout)
STRUCTURES = {"tl_group": Group, "tl_fault": Fault, "tl_part": Part, "tl_read": Read, "tl_clocks": Clocks,
              "tl_link": Link, "tl_instance": Instance, "tl_plan": Plan}


def _cache_root() -> Path:
    root = os.environ.get("TILTLOAD_CACHE") or Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "tiltload"
    return Path(root)


def _compiler() -> str:
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        raise KernelError("no C compiler (cc or gcc) on PATH")
    return cc


_BUILDING = threading.RLock()  # one build at a time in this process; other processes are kept apart by the rename


def _build(cc: str, command: list[str], folder: Path, name: str) -> Path:
    target = folder / f"{name}.so"
    if target.is_file():
        return target
    folder.mkdir(parents=True, exist_ok=True)
    # unique per process and thread: two builders never write the same file, and the rename below publishes one
    partial = folder / f"{name}.{os.getpid()}.{threading.get_ident()}.partial.so"
    proc = subprocess.run([cc, *command, "-o", str(partial)], capture_output=True, text=True)
    if proc.returncode != 0:
        raise KernelError(f"compiling {name} with {cc} failed: {proc.stderr.strip().splitlines()[:1]}")
    partial.replace(target)  # atomic: a parallel process finds either nothing or the whole library
    return target


def _digested(flags, sources) -> list[str]:
    """The flags as the digest takes them: an include folder of a listed source by the content of what is listed, not by
    its path (generated code in a new temporary folder every process is still the same library)."""
    folders = {str(Path(f).parent) for f in sources}
    return [f for f in flags if not (f.startswith("-I") and f[2:] in folders)]


def compiled(name: str, sources, flags=CFLAGS, libraries: tuple[str, ...] = ()) -> ctypes.CDLL:
    """The shared library of these C sources (the .c files compiled, .a archives linked, headers only in the digest),
    built on first use into the cache and loaded. KernelError: no compiler, or it failed."""
    cc = _compiler()
    h = hashlib.sha256()
    for f in sources:
        h.update(Path(f).read_bytes())
    command = [*flags, *(str(f) for f in sources if str(f).endswith((".c", ".a"))), *(f"-l{lib}" for lib in libraries)]
    h.update(" ".join((cc, *_digested(flags, sources), *libraries)).encode())
    digest = h.hexdigest()[:16]
    with _BUILDING:  # the loop and the log writer's thread may ask for the same library at once
        try:
            path = _build(cc, command, _cache_root() / "kernels" / digest, name)
        except OSError:  # no writable cache: a private folder for this process
            path = _build(cc, command, Path(tempfile.mkdtemp(prefix="tiltload_kernel_")), name)
        return ctypes.CDLL(str(path))


@cache
def library() -> ctypes.CDLL:
    """The compiled kernel, with its functions' signatures set and its structs' layout checked against the ctypes
    structures above (layout.LayoutError naming the struct and field that differ)."""
    lib = _with_draws()
    if lib is None:  # noise and jitter are then drawn by numpy in Python (draws_in_c() is False)
        lib = compiled("tl_loop", SOURCES, libraries=("m",))
    else:
        words = ctypes.POINTER(ctypes.c_uint32)
        lib.tl_draw_normal.argtypes = [words, ctypes.c_int, ctypes.c_uint64]
        lib.tl_draw_normal.restype = ctypes.c_double
        lib.tl_draw_bounded.argtypes = [words, ctypes.c_int, ctypes.c_uint64, ctypes.c_uint64]
        lib.tl_draw_bounded.restype = ctypes.c_uint64
    layout.check(lib, STRUCTURES)
    lib.tl_run.argtypes = [ctypes.POINTER(Plan), ctypes.c_int64]
    lib.tl_run.restype = ctypes.c_int64
    lib.tl_close.argtypes = [ctypes.POINTER(Plan), ctypes.c_double]
    lib.tl_close.restype = ctypes.c_int
    lib.tl_store_history.argtypes = [ctypes.POINTER(Plan), ctypes.c_int64]
    lib.tl_store_history.restype = None
    lib.tl_link_yield.argtypes = [ctypes.POINTER(Link)]
    lib.tl_link_yield.restype = ctypes.c_int
    lib.tl_monotonic_ns.argtypes = []
    lib.tl_monotonic_ns.restype = ctypes.c_int64
    p, n = ctypes.c_void_p, ctypes.c_int64  # tl_mcap.c: arrays by address
    for name, args, result in (("tl_mcap_messages", [n, p, p, p, p, p, p], None),
                               ("tl_mcap_message_indexes", [n, p, p, p, n, p, p, p, p, p], n),
                               ("tl_mcap_fill", [n, n, p, p, p, p, n, p, n, p, p, p, p, p, n], n)):
        getattr(lib, name).argtypes, getattr(lib, name).restype = args, result
    return lib


def _with_draws() -> ctypes.CDLL | None:
    """The kernel linked with numpy's C random library, or None if this numpy has none or it does not link here
    (an archive built for another toolchain, a compiler without 128-bit integers)."""
    numpy_random = _numpy_random()
    if numpy_random is None:
        return None
    archive, include = numpy_random
    try:
        return compiled("tl_loop", (*SOURCES, *DRAWS, archive), (*CFLAGS, "-DTL_DRAWS", f"-I{include}"), ("m",))
    except (KernelError, OSError):
        return None


def _numpy_random() -> tuple[Path, Path] | None:
    """numpy's C random library (libnpyrandom.a, shipped for C consumers) and its bitgen.h folder, if this numpy has
    them: the kernel draws the noise fault's normals with numpy's own ziggurat, so C and Python draw the same."""
    import numpy

    archive = Path(numpy.__file__).parent / "random" / "lib" / "libnpyrandom.a"
    include = Path(numpy.get_include())
    return (archive, include) if archive.is_file() and (include / "numpy" / "random" / "bitgen.h").is_file() else None


def draws_in_c() -> bool:
    """The kernel applies the noise fault itself (this numpy ships its C random library)."""
    return hasattr(library(), "tl_draw_normal")


def entropy_words(*values: int) -> list[int]:
    """numpy's SeedSequence words of these non-negative integers (each little-endian in 32-bit words, 0 as [0])."""
    out = []
    for v in values:
        out.extend([v & 0xFFFFFFFF] if v == 0 else [(v >> s) & 0xFFFFFFFF for s in range(0, v.bit_length(), 32)])
    return out

