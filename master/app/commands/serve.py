"""`tiltload serve`: this machine hosts the FMUs of a folder for masters elsewhere (docs/remote.md).

The options are master/command_line/serve.py's, the serving the engine's (isolation/server.py); a board without the
whole application runs the same as `python -m tiltload.master.command_line.serve`.
"""

from __future__ import annotations

import argparse


def add_parser(sub) -> None:
    from ...command_line.serve import add_arguments

    s = sub.add_parser("serve", help="host the FMUs of a folder for a master on another machine "
                                     "(tiltload run --remote INSTANCE=HOST:PORT; docs/remote.md)")
    add_arguments(s)
    s.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ...command_line.serve import ServeError
    from ...command_line.serve import run as serve
    from ..errors import UserError

    try:
        return serve(args)
    except ServeError as err:
        raise UserError(str(err)) from None
