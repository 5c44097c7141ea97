"""The case core: what one run is, whatever face asks for it (the command line, `tl.run`, a campaign case, a search
point, a branch from a snapshot, a replay). One description of a run (`options`: `LoopOptions`, every default filled in,
the defaults themselves in `defaults`), one builder of its system (`system`: `build_system`), one grammar of what varies
between the runs of a case set (`targets`), the flight a case set shares (`flight`) and the spec files that describe
case sets (`spec_file`). docs/architecture.md, "The application"."""

_PUBLIC = {  # name: the module it is defined in
    "LoopOptions": "options", "resolve_loop": "options", "snapshot_options": "options", "LoopSystem": "system",
    "build_system": "system", "case_system": "system", "branch_system": "system", "Flight": "flight", "SpecError": "spec_file",
}
__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    """The public names load on first use: importing the package imports none of its modules."""
    if name in _PUBLIC:
        from importlib import import_module

        return getattr(import_module(f"{__name__}.{_PUBLIC[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
