"""The shared-memory link to an isolated FMU's host (native/tl_link.h): the tick loop steps the FMU in its worker
process itself, one round trip a step through a sealed memfd segment and a futex, with no Python on either side
(tl_loop.c's step_linked, the host's c/tl_host.c; an FMU with clocks stepped there by the kernel's own sequence,
host_plan.py). The pipe stays for everything else (initialization, states,
resets, close, errors' log lines): the master yields the link before each such request and takes it again before the
next ticks.

Master's side: `Segment` (the memfd, sized from the model, sealed so the host cannot shrink it under the master's
reads) and `plan_link` (where each input group and the outputs go). Host's side: `HostLink`, the C loop's arguments
built from the master's request after checking it against the model and the segment.
"""

from __future__ import annotations

import ctypes
import fcntl
import mmap
import os
import sys
from pathlib import Path

from ..native import kernel
from .host_plan import HostPlan

TYPES = ("Real", "Integer", "Boolean")  # the kernel's value types, in its order
WIDTH = {"Real": 8, "Integer": 4, "Boolean": 4}  # as the plan's arrays hold them (fmi2Boolean is an int)
REQUEST, REPLY, CALL, INPUTS, HEADER = 0, 64, 128, 192, 64  # tl_link.h
SPIN_NS = 30_000  # spin at least this long before sleeping on the futex (longer where the answer usually comes later: tl_link.h)
HOST = (Path(__file__).parent / "c" / "tl_host.c", kernel.HERE / "tl_link.h", kernel.HERE / "tl_codes.h")


def available() -> bool:
    """The link needs Linux's memfd, seals and futexes."""
    return sys.platform.startswith("linux") and hasattr(os, "memfd_create") and hasattr(fcntl, "F_ADD_SEALS")


def _align(n: int, to: int) -> int:
    return (n + to - 1) // to * to


def segment_size(n_inputs: int, counts: dict[str, int]) -> tuple[int, int]:
    """(bytes of the segment, the reply's offset) for a model of n_inputs inputs and counts outputs per type: each
    input at most once in the groups (a connection each), 8-aligned groups."""
    out_offset = _align(INPUTS + 8 * n_inputs + 8 * (n_inputs + 1), 64)
    size = out_offset + HEADER + sum(WIDTH[t] * counts.get(t, 0) for t in TYPES)
    return _align(size, mmap.PAGESIZE), out_offset


class Segment:
    """The master's memfd segment: created, sized, sealed (no shrinking, no growing), mapped."""

    def __init__(self, name: str, size: int, out_offset: int) -> None:
        self.size, self.out_offset = size, out_offset
        self.fd = os.memfd_create(f"tiltload-{name}", os.MFD_CLOEXEC | os.MFD_ALLOW_SEALING)
        try:
            os.ftruncate(self.fd, size)
            fcntl.fcntl(self.fd, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SHRINK | fcntl.F_SEAL_GROW | fcntl.F_SEAL_SEAL)
            self.map = mmap.mmap(self.fd, size)
        except BaseException:
            os.close(self.fd)
            raise
        self._anchor = ctypes.c_char.from_buffer(self.map)
        self.address = ctypes.addressof(self._anchor)

    def close(self) -> None:
        if self.map is None:
            return
        del self._anchor
        self.map.close()
        os.close(self.fd)
        self.map = None


def plan_link(groups: list[tuple[str, int]], out_offset: int) -> list[int]:
    """Each group's offset (groups: (type, n) in the loop's order); ValueError if they do not fit before the reply."""
    offsets, at = [], INPUTS
    for typ, n in groups:
        offsets.append(at)
        at = _align(at + WIDTH[typ] * n, 8)
    if at > out_offset:
        raise ValueError(f"the inputs take {at - INPUTS} bytes, the segment has {out_offset - INPUTS}")
    return offsets


# ---- the host's side ----------------------------------------------------------------------------------------------
class _Host(ctypes.Structure):  # tl_host.c's tl_host
    _fields_ = [("base", ctypes.c_void_p), ("size", ctypes.c_int64), ("request_fd", ctypes.c_int),
                ("seq", ctypes.c_uint32), ("spin_ns", ctypes.c_int64), ("fmi3", ctypes.c_int),
                ("component", ctypes.c_void_p), ("do_step", ctypes.c_void_p), ("boolean_status", ctypes.c_void_p),
                ("real_status", ctypes.c_void_p), ("do_step3", ctypes.c_void_p), ("set", ctypes.c_void_p * 3),
                ("get", ctypes.c_void_p * 3), ("n_groups", ctypes.c_int), ("group_type", ctypes.c_void_p),
                ("group_n", ctypes.c_void_p), ("group_vrs", ctypes.c_void_p), ("in_offset", ctypes.c_void_p),
                ("n_out", ctypes.c_int * 3), ("out_vrs", ctypes.c_void_p * 3), ("out_offset", ctypes.c_int64),
                ("booleans", ctypes.c_void_p), ("usual_gap_ns", ctypes.c_int64), ("alone", ctypes.c_void_p),
                ("step_alone", ctypes.c_void_p), ("group_values", ctypes.c_void_p), ("out", ctypes.c_void_p * 3)]


def host_library() -> ctypes.CDLL:
    lib = kernel.compiled("tl_host", HOST, (*kernel.CFLAGS, f"-I{kernel.HERE}"))
    lib.tl_host_serve.argtypes = [ctypes.POINTER(_Host)]
    lib.tl_host_serve.restype = ctypes.c_int
    return lib


class LinkRefused(Exception):
    """The master's request for the link does not fit the model or the segment."""


class HostLink:
    """The host's loop over the segment (fd, mapped here too) for the loaded slave inst, as the master's request
    describes it; serve() answers steps until the master yields."""

    def __init__(self, fd: int, request_fd: int) -> None:
        size = os.fstat(fd).st_size
        self.map = mmap.mmap(fd, size)
        self._anchor = ctypes.c_char.from_buffer(self.map)
        self.size, self.request_fd = size, request_fd
        self.lib = host_library()
        self.host: _Host | None = None
        self._keep: list = []
        self.plan: HostPlan | None = None  # an FMU with clocks: the kernel's plan of it, kept while the groups are the same

    def bind(self, inst, request: dict, inputs: dict[str, frozenset]) -> None:
        """The C loop's arguments for inst from the master's request {"groups": [[type, [vrs]]], "in_offset": [...],
        "out_offset", "seq"}: every set only of the model's inputs, every offset within the segment."""
        try:
            groups = [(str(t), [int(v) for v in vrs]) for t, vrs in request["groups"]]
            offsets = [int(x) for x in request["in_offset"]]
            out_offset, seq = int(request["out_offset"]), int(request["seq"])
        except (KeyError, TypeError, ValueError):
            raise LinkRefused("malformed link request") from None
        if len(offsets) != len(groups):
            raise LinkRefused("a link request whose offsets are not its groups'")
        for (typ, vrs), at in zip(groups, offsets):
            if typ not in WIDTH or any(v not in inputs.get(typ, ()) for v in vrs):
                raise LinkRefused(f"a link sets a {typ} that is not an input of this model")
            if not INPUTS <= at or at + WIDTH[typ] * len(vrs) > out_offset or at % 8:
                raise LinkRefused("a group's offset outside the inputs' room")
        counts = {t: inst.values[t].size for t in TYPES}
        if out_offset < INPUTS or out_offset + HEADER + sum(WIDTH[t] * counts[t] for t in TYPES) > self.size:
            raise LinkRefused("the outputs do not fit the segment")
        fmi3 = type(inst).__name__ != "InProcessFmu"
        h = _Host(base=ctypes.addressof(self._anchor), size=self.size, request_fd=self.request_fd, seq=seq & 0xFFFFFFFF,
                  spin_ns=SPIN_NS, fmi3=int(fmi3), component=inst.component, out_offset=out_offset)
        fn = inst.function_pointer
        if fmi3:
            h.do_step3 = fn("fmi3DoStep")
            names = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}
            for k, t in enumerate(TYPES):
                h.set[k], h.get[k] = fn(f"fmi3Set{names[t]}"), fn(f"fmi3Get{names[t]}")
        else:
            h.do_step, h.boolean_status, h.real_status = fn("fmi2DoStep"), fn("fmi2GetBooleanStatus"), fn("fmi2GetRealStatus")
            for k, t in enumerate(TYPES):
                h.set[k], h.get[k] = fn(f"fmi2Set{t}"), fn(f"fmi2Get{t}")
        n = max(len(groups), 1)
        types = (ctypes.c_int * n)(*(TYPES.index(t) for t, _ in groups))
        sizes = (ctypes.c_int * n)(*(len(v) for _, v in groups))
        vr_arrays = [(ctypes.c_uint * max(len(v), 1))(*v) for _, v in groups]
        vrs = (ctypes.c_void_p * n)(*(ctypes.addressof(a) for a in vr_arrays))
        offs = (ctypes.c_int64 * n)(*offsets)
        out_vrs = [(ctypes.c_uint * max(counts[t], 1))(*inst.out_vrs[t]) for t in TYPES]
        booleans = (ctypes.c_bool * max([counts["Boolean"], *(len(v) for t, v in groups if t == "Boolean"), 1]))()
        h.n_groups, h.group_type, h.group_n = len(groups), ctypes.addressof(types), ctypes.addressof(sizes)
        h.group_vrs, h.in_offset, h.booleans = ctypes.addressof(vrs), ctypes.addressof(offs), ctypes.addressof(booleans)
        for k, t in enumerate(TYPES):
            h.n_out[k], h.out_vrs[k] = counts[t], ctypes.addressof(out_vrs[k])
        self._keep = [types, sizes, vr_arrays, vrs, offs, out_vrs, booleans]
        if getattr(inst, "clocked", False):  # Event Mode, or Scheduled Execution: the kernel's own sequence steps it
            if self.plan is None or self.plan.slave is not inst or self._plan_groups != groups:
                self.plan, self._plan_groups = HostPlan(inst, groups), groups
            h.alone, h.step_alone, h.group_values = self.plan.alone, self.plan.step_alone, ctypes.addressof(self.plan.group_values)
            for k in range(len(TYPES)):
                h.out[k] = self.plan.out[k]
        self.host = h

    def forget_inputs(self) -> None:
        """After a reset of the FMU: no discrete input of a clocked one was set yet."""
        if self.plan is not None:
            self.plan.forget_inputs()

    def serve(self) -> bool:
        """Answer steps in C until the master yields (True) or is gone (False)."""
        if self.host.alone:
            self.plan.take()
        try:
            return self.lib.tl_host_serve(ctypes.byref(self.host)) == 0
        finally:
            if self.host.alone:
                self.plan.leave()
