"""One module per `tiltload` command: add_parser(subparsers) declares its options, run(args) does it and returns
the exit code. Errors the user can fix are raised (errors.USER_ERRORS) and reported by cli.main in one line."""
