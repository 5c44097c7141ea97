"""One module per `tiltload` command: add_parser(subparsers) declares its options, run(args) does it and returns
the exit code. Errors are raised and reported by cli.main in one line, with the exit code of their kind (errors.KINDS)."""
