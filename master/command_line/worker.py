"""The command line of a process that hosts one FMU (engine/isolation/worker.py): what the master (isolation/process.py)
or `tiltload serve` (isolation/server.py) start as `python -m tiltload.master.command_line.worker FMU NAME --pipes R W`
or `... --socket FD`; not meant to be typed."""

from __future__ import annotations

import argparse
import ctypes
import signal
import socket

from ..engine.fmi.pythonfmu_guard import exit_now
from ..engine.isolation.transport import Channel, LinkClosed
from ..engine.isolation.worker import labelled, serve
from .argument_types import DAY, time_span


def _die_with_parent() -> None:
    """Linux: be killed when the master (or the server) dies, even while hung inside the FMU."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass  # elsewhere a dead master still closes the link, which ends the loop


def main() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the master's (or the server's) to handle
    _die_with_parent()
    p = argparse.ArgumentParser(prog="worker", allow_abbrev=False)
    p.add_argument("fmu")
    p.add_argument("name")
    link = p.add_mutually_exclusive_group(required=True)
    link.add_argument("--pipes", type=int, nargs=2, metavar=("REQUESTS", "REPLIES"))
    link.add_argument("--socket", type=int, metavar="FD")
    p.add_argument("--idle-timeout", type=time_span(DAY), default=None)
    p.add_argument("--label", default="")
    p.add_argument("--tick", type=time_span(DAY), default=None)  # the master's, for an FMI 3.0 FMU's clocks
    p.add_argument("--shm", type=int, default=None)  # the master's shared-memory segment (isolation/link.py)
    args = p.parse_args()
    if args.socket is not None:
        channel = Channel.over_socket(socket.socket(fileno=args.socket))
    else:
        channel = Channel.over_pipes(*args.pipes)
    try:
        code = serve(args.fmu, args.name, channel, args.idle_timeout, labelled(args.label), args.tick,
                     shm=args.shm if args.pipes is not None else None)
    except LinkClosed:
        code = 0
    channel.close()  # a socket is shut down: the master sees the end at once
    exit_now(code)  # no interpreter shutdown: a pythonfmu FMU can crash in it


if __name__ == "__main__":
    main()
