"""Command lines over the engine: argparse lives here, the engine offers functions. The checked argument types shared by
every command line of the project, every wait bounded (`argument_types`), and `tiltload serve`'s options and its run
(`serve`), also run alone on a board that has only the engine's dependencies:
`python -m tiltload.master.command_line.serve` (docs/remote.md). Standard library and the engine only: nothing here is
imported when the package is."""
