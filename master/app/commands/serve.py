"""`tiltload serve`: this machine hosts the FMUs of a folder for masters elsewhere (docs/remote.md)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments


def address(text: str) -> tuple[str, int]:
    from ...engine.system import parse_address

    try:
        return parse_address(text, port_zero=True)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def add_parser(sub) -> None:
    s = sub.add_parser("serve", help="host the FMUs of a folder for a master on another machine "
                                     "(tiltload run --remote INSTANCE=HOST:PORT; docs/remote.md)")
    s.add_argument("--fmus", type=Path, default=arguments.DEFAULT_FMU_DIR,
                   help="the folder whose FMUs are served, built for this machine (default: fmus); nothing else is")
    s.add_argument("--bind", type=address, default=("127.0.0.1", 7390), metavar="HOST:PORT",
                   help="where to listen (default 127.0.0.1:7390, this machine only; 0.0.0.0:7390 or the board's "
                        "address for a master elsewhere; port 0 picks a free one)")
    s.add_argument("--token-file", type=Path, required=True, metavar="FILE",
                   help="the shared secret (at least 16 bytes, readable by you only) a master must prove, as "
                        "tiltload run --token-file")
    s.add_argument("--clients-per-fmu", type=arguments.whole_number, default=1, metavar="N",
                   help="sessions one FMU serves at a time (default 1)")
    s.add_argument("--handshake-timeout", type=arguments.positive_time, default=5.0, metavar="S",
                   help="the time a client has from connecting to naming its FMU (default 5 s)")
    s.add_argument("--idle-timeout", type=arguments.positive_time, default=600.0, metavar="S",
                   help="a session ends after this long without a request from its master (default 600 s)")
    s.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ...engine.isolation.handshake import read_token
    from ...engine.isolation.server import ServeOptions, Server
    from ..errors import UserError

    if not args.fmus.is_dir():
        raise UserError(f"--fmus {args.fmus}: no such folder")
    host, port = args.bind
    server = Server(ServeOptions(args.fmus.resolve(), read_token(args.token_file), host, port, args.clients_per_fmu,
                                 args.handshake_timeout, args.idle_timeout))
    try:
        server.start()
    except OSError as err:
        raise UserError(f"cannot listen on {host}:{port}: {err.strerror or err}") from None
    try:
        server.serve_forever()
    except KeyboardInterrupt as err:  # Ctrl-C, or SIGTERM (cli.entry makes it one)
        server.say(f"stopped ({'SIGTERM' if getattr(err, 'signum', 2) == 15 else 'SIGINT'}); every session ended")
    return 0
