"""The command line of `tiltload serve`, also run as `python -m tiltload.master.command_line.serve` on a board
that has only numpy and FMPy (the engine's own dependencies), not the whole application (docs/remote.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..engine.errors import DescriptionError
from ..engine.isolation.server import DEFAULT_PORT, ServeOptions, Server
from .argument_types import DAY, integer, time_span
from .path_types import existing_folder


class ServeError(Exception):
    """The server cannot start (a missing folder, a bad token file, an address it cannot listen on): one line."""


def _address(text: str) -> tuple[str, int]:
    from ..engine.system import parse_address

    try:
        return parse_address(text, port_zero=True)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


MAX_HANDSHAKE = 3600.0  # s: a client names its FMU in milliseconds; an hour is generous and far from any overflow
MAX_CLIENTS_PER_FMU = 1024


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--fmus", type=existing_folder, default=Path("fmus"),
                   help="the folder whose FMUs are served, built for this machine (default: fmus); nothing else is")
    p.add_argument("--bind", type=_address, default=("127.0.0.1", DEFAULT_PORT), metavar="HOST:PORT",
                   help=f"where to listen (default 127.0.0.1:{DEFAULT_PORT}, this machine only; 0.0.0.0:{DEFAULT_PORT} or "
                        "the board's address for a master elsewhere; port 0 picks a free one)")
    p.add_argument("--token-file", type=Path, required=True, metavar="FILE",
                   help="the shared secret (at least 16 bytes, readable by you only) a master must prove, as "
                        "tiltload run --token-file")
    p.add_argument("--clients-per-fmu", type=integer(1, MAX_CLIENTS_PER_FMU), default=1, metavar="N",
                   help=f"sessions one FMU serves at a time (default 1; at most {MAX_CLIENTS_PER_FMU})")
    p.add_argument("--handshake-timeout", type=time_span(MAX_HANDSHAKE), default=5.0, metavar="S",
                   help=f"the time a client has from connecting to naming its FMU (default 5 s; at most {MAX_HANDSHAKE:g} s)")
    p.add_argument("--idle-timeout", type=time_span(DAY), default=600.0, metavar="S",
                   help=f"a session ends after this long without a request from its master (default 600 s; at most {DAY:g} s)")


def run(args: argparse.Namespace) -> int:
    """Serve until Ctrl-C or SIGTERM (raised as KeyboardInterrupt); ServeError if it cannot start."""
    from ..engine.isolation.handshake import read_token

    try:
        secret = read_token(args.token_file)
    except DescriptionError as err:
        raise ServeError(str(err)) from None
    host, port = args.bind
    server = Server(ServeOptions(args.fmus.resolve(), secret, host, port, args.clients_per_fmu, args.handshake_timeout,
                                 args.idle_timeout))
    try:
        server.start()
    except OSError as err:
        raise ServeError(f"cannot listen on {host}:{port}: {err.strerror or err}") from None
    try:
        server.serve_forever()
    except KeyboardInterrupt as err:
        server.say(f"stopped ({'SIGTERM' if getattr(err, 'signum', 2) == 15 else 'SIGINT'}); every session ended")
    return 0


class _Terminated(KeyboardInterrupt):
    signum = 15


def main() -> None:
    import signal

    def terminated(signum, frame):
        raise _Terminated()
    signal.signal(signal.SIGTERM, terminated)
    p = argparse.ArgumentParser(prog="python -m tiltload.master.command_line.serve", allow_abbrev=False,
                                description="Serve the FMUs of a folder to tiltload masters elsewhere (docs/remote.md).")
    add_arguments(p)
    try:
        sys.exit(run(p.parse_args()))
    except ServeError as err:
        print(f"{p.prog}: error: {err}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
