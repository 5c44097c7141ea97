"""Requirements: named STL requirements over logged signals (docs/requirements.md). The requirement files and their
sugar (`files`), a run's trace checked on the tick with its verdicts (`check`: `check_log`), the same online during a
run (`observer`: `RequirementObserver`), and the Signal Temporal Logic they are written in (`stl/`: generic, it knows
nothing of FMUs or logs)."""

_PUBLIC = {  # name: the module it is defined in
    "Requirement": "files", "RequirementError": "files", "load": "files", "from_option": "files",
    "Result": "check", "check_log": "check", "RequirementObserver": "observer", "RequirementViolated": "observer",
}
__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    """The public names load on first use: importing the package imports none of its modules."""
    if name in _PUBLIC:
        from importlib import import_module

        return getattr(import_module(f"{__name__}.{_PUBLIC[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
