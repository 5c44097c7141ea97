"""The thesis's loop, whatever runs it: its system (`thesis`: the instance names, the FMUs, the metrics, the loop delay),
the controller's port contract (`ports`), the FMUs' recipes and where they run (`fmus`: the isolation policy), the
scenario's files (`inputs`), the FMU parameters' types (`parameter_types`) and the 3D scene for the log (`scene`, with
its encoder scene.c). docs/architecture.md, "The application"."""
