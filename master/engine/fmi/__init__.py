"""FMI: one FMU in this process. Its description (`model_description`: read, values checked), the interface of one
instance (`slave`), the bindings (`fmi2`; `fmi3` with its state's bytes in `fmi3_state`; `fmi3_scheduled`; what they
share in `binding`), the one place that picks a binding by FMI version (`in_process.load`), and the FMU on disk: which
binaries this machine loads (`binaries`), the per-machine unpacked cache (`fmu_cache`), private copies that never
outlive their process (`extraction`), and pythonfmu's pin (`pythonfmu_guard`). FMUs hosted elsewhere: ../isolation/."""

_PUBLIC = {  # name: the module it is defined in
    "read_fmu": "model_description", "fmi_version": "model_description", "is_scheduled": "model_description",
    "checked_value": "model_description", "Slave": "slave", "load": "in_process", "unpacked": "fmu_cache",
    "digest": "fmu_cache", "pin": "pythonfmu_guard", "exit_now": "pythonfmu_guard",
}
__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    """The public names load on first use: importing the package imports none of its modules."""
    if name in _PUBLIC:
        from importlib import import_module

        return getattr(import_module(f"{__name__}.{_PUBLIC[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
