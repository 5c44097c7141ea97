"""What the FMI 2.0 and FMI 3.0 bindings (fmi2.py, fmi3.py) share: an FMU extracted and instantiated in this process
through FMPy, calls timed and turned into one-line errors, parameters set by name, and the teardown.

Each binding adds only what its standard's functions differ in: the raw ctypes functions of the hot path, the
initialization sequence, the state calls (and for FMI 3.0 the clocks' Event Mode)."""

from __future__ import annotations

import ctypes
import time
from pathlib import Path

from fmpy.fmi1 import FMICallException

from ..errors import ExecutionError
from .fmu_cache import unpacked
from .model_description import checked_value, fmi_type
from .slave import Slave


def fmpy_call(slave: Slave, what: str, fn):
    """fn() through FMPy, timed into the slave's fmi_seconds; a refused call becomes the slave's one-line error."""
    started = time.perf_counter()
    try:
        return fn()
    except FMICallException as err:
        raise slave.failed(what, err.status) from None
    except OSError as err:
        raise ExecutionError(f"{slave.name}: {what} failed: {err}") from None
    finally:
        slave.fmi_seconds += time.perf_counter() - started


def c_function(dll, name: str, argtypes: list):
    """One of the FMU's own functions, typed for ctypes: it returns an FMI status (an int in both standards)."""
    fn = getattr(dll, name)
    fn.argtypes = argtypes
    fn.restype = ctypes.c_int
    return fn


class Binding(Slave):
    """An FMU instantiated in this process through FMPy's object for its standard (FMU2Slave, FMU3Slave)."""

    # FMPy's setter of a parameter of each type (fmi_type), by method name: the standards name the types differently
    PARAMETER_SETTERS: dict[str, str] = {}

    def __init__(self, name: str, path: Path, md) -> None:
        super().__init__(name, path, md)
        self._closed = False
        self._unpacked = None  # fmu_cache.Cached or extraction.Unpacked, from _load
        self._fmpy = None
        self.text_outputs = [v for v in md.modelVariables if v.causality == "output" and fmi_type(v) in ("String", "Binary")]

    def function_pointer(self, name: str) -> int:
        """The address of one of the FMU's own functions (fmi2DoStep, fmi3SetClock, ...), for the C tick loop."""
        return ctypes.cast(getattr(self._fmpy.dll, name), ctypes.c_void_p).value

    def _load(self, make, instantiate):
        """FMPy's object for the FMU, make(its extracted folder), instantiated by instantiate(that object). Nothing of a
        failed instantiation stays behind; the extracted copy goes with close(), or with its reaper if this process
        dies first."""
        self._unpacked = unpacked(self.path)  # the machine's cached copy (fmu_cache.py), or a private one close() removes
        self.dir = self._unpacked.folder
        try:
            self._fmpy = make(self.dir)
            self.call("instantiate", lambda: instantiate(self._fmpy))
        except BaseException:
            self._unpacked.release()
            raise
        return self._fmpy

    def call(self, what: str, fn):
        return fmpy_call(self, what, fn)

    def read_texts(self) -> None:
        """The String and Binary outputs now into texts (the loop steps such an FMU through its Python callback)."""
        for v in self.text_outputs:
            if fmi_type(v) == "Binary":
                value = self.call(f"getBinary({v.name})", lambda vr=v.valueReference: self._fmpy.getBinary([vr])[0])
            else:
                value = self.call(f"getString({v.name})", lambda vr=v.valueReference: self._fmpy.getString([vr])[0])
                value = value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)
            self.texts[v.name] = value

    def set_values(self, values: dict) -> None:
        self.set_parameters(values)

    def set_parameters(self, params: dict) -> None:
        for key, value in params.items():
            v = self.vars.get(key)
            value = checked_value(self.name, v, key, value)
            setter = getattr(self._fmpy, self.PARAMETER_SETTERS[fmi_type(v)])
            self.call(f"setting {key}", lambda s=setter, vr=v.valueReference, x=value: s([vr], [x]))

    def close(self) -> None:
        """Terminate and free the instance, then remove its extracted copy (a run leaves no folder behind); safe to call
        twice."""
        if self._closed:
            return
        self._closed = True
        if not self.fatal:  # after a Fatal status the standards allow no call, not even freeInstance
            try:
                self._fmpy.terminate()
            except Exception:
                pass
            try:
                self._fmpy.freeInstance()
            except Exception:
                pass
        self._unpacked.release()
