"""PythonController: a Python controller class as the controller of a Case, and how it becomes an FMU."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PythonController:
    """A controller class (docs/ports.md: inputs, parameters, period, step) as a Case's controller, wrapped into an FMU
    the way `tiltload wrap` wraps it and cached by content (wrap/class_fmu.py). ``Case(controller=MyController)`` is
    ``Case(controller=PythonController(MyController))``.

    native: None (default): a native C FMU (`wrap --native`) if the class traces, else a pythonfmu FMU (`wrap`);
    True: native, a class that cannot be traced refused; False: pythonfmu."""

    cls: type
    native: bool | None = None

    def __post_init__(self) -> None:
        if self.native is not None and not isinstance(self.native, bool):
            raise TypeError(f"PythonController.native must be None, True or False, got {type(self.native).__name__}")


def is_python_file(controller: object) -> bool:
    """A controller given as the path of a class's .py file (`--controller my_controller.py`)."""
    return isinstance(controller, str) and controller.endswith(".py")


def controller_fmu_path(controller: type | PythonController | str, fmi_version: int) -> str:
    """The FMU of a Python controller (a class, a PythonController or a class's .py file), built once per content;
    TiltloadError if it cannot be wrapped."""
    from ..wrap.class_fmu import controller_fmu, controller_fmu_of_file
    from .errors import as_tiltload_errors

    with as_tiltload_errors():
        if is_python_file(controller):
            return str(controller_fmu_of_file(controller, None, fmi_version))
        given = controller if isinstance(controller, PythonController) else PythonController(controller)
        return str(controller_fmu(given.cls, given.native, fmi_version))

