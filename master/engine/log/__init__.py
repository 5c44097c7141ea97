"""The run's MCAP log: the logger, an observer (`logger`: `McapLogger`, `DerivedChannel`), the bulk writer that encodes
and compresses in a thread of its own (`writer`), the records' fixed layout (`encoding`), the checked readers
(`reader`), and what a run ran, for a log and a baseline (`provenance`). docs/master.md, Logs."""

_PUBLIC = {  # name: the module it is defined in
    "McapLogger": "logger", "DerivedChannel": "logger", "McapWriter": "writer", "read_log": "reader",
    "read_columns": "reader", "read_metadata": "reader", "DamagedLog": "reader", "ForeignLog": "reader",
    "fmus_record": "provenance", "units_record": "provenance",
}
__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    """The public names load on first use: importing the package imports none of its modules."""
    if name in _PUBLIC:
        from importlib import import_module

        return getattr(import_module(f"{__name__}.{_PUBLIC[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
