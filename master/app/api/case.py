"""Case: what one run of the loop (or of a system file) is, as the user says it; checked when built. The command line
(`tiltload run`'s loop options) and the Python API (`tiltload.Case`, `tiltload.run(**keywords)`) build the same object;
options.resolve_loop fills in its defaults (a LoopOptions, what the system is built from and a snapshot records)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..case.fields import CASE
from ..loop.defaults import MAX_TILT
from . import field_types as kinds
from .command_line import text_of
from .field_types import closest_field
from .python_controller import PythonController, controller_fmu_path, is_python_file

if TYPE_CHECKING:
    from ..case.options import LoopOptions


@closest_field
@dataclass(frozen=True, kw_only=True)
class Case:
    """One run: the field names are `tiltload run`'s options (``--stop-time`` is ``stop_time``); None is the
    option's default (the vehicle's trajectory and controller, seed 1, the trajectory's duration, ...).

    controller: dlqr, mixed, a controller FMU's path, or a Python controller class (or a PythonController), wrapped
    into an FMU as `tiltload wrap` does, once per content (the field then holds that FMU's path). set: FMU parameters
    {"instance.name": number, bool or text} (checked against the FMU's type when the system is built). remote:
    {"instance": "host:port"} of a tiltload serve.
    A wrong type raises TypeError naming the field; a wrong value TiltloadError with the command's line."""

    vehicle: str | None = None  # load (default) or uav
    scenario: str | None = None  # fsi, lkf, zse (default)
    trajectory: int | str | None = None  # 0-3, a shape ("step-z:size=0.5") or a waypoint file
    controller: str | type | PythonController | None = None
    seed: int | None = None
    stop_time: float | None = None  # s
    delay: bool = False
    no_gusts: bool = False
    wind: Path | None = None
    faults: Path | None = None
    set: tuple[tuple[str, object], ...] = ()
    system: Path | None = None  # an SSP package or JSON system description instead of the loop
    schedule: str | None = None  # ordered (tiltload's) or jacobi
    fmi: int | None = None  # 2 (default) or 3
    clocks: bool = False
    fmus: Path | None = None  # default: fmus
    remote: tuple[tuple[str, str], ...] = ()
    allow_infeasible: bool = False
    max_tilt: float = MAX_TILT  # degrees
    allow_unknown_inputs: bool = False
    allow_external_fmus: bool = False
    step: float | None = None  # s: the step of a system package that declares none
    start_time: float | None = None  # s: the time a system starts at (its file's by default); stop_time is absolute
    input_file: tuple[tuple[str, str], ...] = ()  # {instance: CSV or Parquet file of its inputs over time}

    def __post_init__(self) -> None:
        fix = self._fix
        for name in ("vehicle", "scenario", "schedule"):
            fix(name, kinds.text("Case", name, getattr(self, name)))
            CASE.choose(name, getattr(self, name))  # the core's field types (case/fields.py), as the command's parser
        self._trajectory_and_controller()
        if fix("seed", kinds.whole("Case", "seed", self.seed)) is not None:
            CASE.check("seed", self.seed)
        for name in ("step", "start_time"):
            if fix(name, kinds.number("Case", name, getattr(self, name))) is not None:
                fix(name, CASE.check(name, getattr(self, name)))
        if fix("stop_time", kinds.number("Case", "stop_time", self.stop_time)) is not None:
            fix("stop_time", CASE.check("stop_time", self.stop_time))
        for name in ("delay", "no_gusts", "clocks", "allow_infeasible", "allow_unknown_inputs", "allow_external_fmus"):
            kinds.flag("Case", name, getattr(self, name))
        for name in ("wind", "faults", "system", "fmus"):
            fix(name, kinds.path("Case", name, getattr(self, name)))
        if self.fmus is not None:
            CASE.check("fmus", self.fmus)
        if fix("fmi", kinds.whole("Case", "fmi", self.fmi)) is not None:
            CASE.choose("fmi", self.fmi)
        fix("max_tilt", CASE.check("max_tilt", kinds.number("Case", "max_tilt", self.max_tilt, False)))
        self._settings_and_remotes()
        if self._python_controller() and self.system is None:  # with a system file the controller is refused below
            fix("controller", controller_fmu_path(self.controller, self.fmi or 2))  # its path: what the run and log name
        from ..case.options import resolve_loop
        from .errors import as_tiltload_errors

        # what needs the vehicle's choices or a file, with the command's lines; kept (no field: not compared, not shown);
        # a trajectory, wind or fault file's error is the user's to fix, as the command says it: TiltloadError
        with as_tiltload_errors():
            object.__setattr__(self, "_resolved", resolve_loop(self))

    def loop_options(self) -> LoopOptions:
        """The case with every default filled in (what the system is built from and a snapshot records)."""
        return self._resolved

    def _fix(self, name: str, value: object) -> object:
        object.__setattr__(self, name, value)  # frozen: normalized once, while built
        return value

    def _trajectory_and_controller(self) -> None:
        if isinstance(self.trajectory, Path):
            self._fix("trajectory", str(self.trajectory))
        if isinstance(self.trajectory, str) and self.trajectory.isdecimal():  # the command line's "2" is trajectory 2
            self._fix("trajectory", int(self.trajectory))
        if self.trajectory is not None and (isinstance(self.trajectory, bool) or not isinstance(self.trajectory, (int, str))):
            raise TypeError(f"Case.trajectory must be a number 0-3, a shape or a file (int, str or Path), got "
                            f"{type(self.trajectory).__name__} {self.trajectory!r:.80}")
        if isinstance(self.controller, Path):
            self._fix("controller", str(self.controller))
        if not isinstance(self.controller, (type, PythonController)):
            kinds.text("Case", "controller", self.controller)

    def _python_controller(self) -> bool:
        return isinstance(self.controller, (type, PythonController)) or is_python_file(self.controller)

    def _settings_and_remotes(self) -> None:
        settings = kinds.pairs("Case", "set", self.set, (int, float, bool, str), "a number, bool or str")
        for key, value in settings:  # the command's check, on the text the command would have been given
            CASE.check("set", f"{key}={text_of(value)}")
        self._fix("set", settings)
        remotes = kinds.pairs("Case", "remote", self.remote, (str,), "a str host:port")
        self._fix("remote", tuple(CASE.check("remote", f"{k}={v}") for k, v in remotes))
        tables = kinds.pairs("Case", "input_file", self.input_file, (str, Path), "a file path")
        self._fix("input_file", tuple(CASE.check("input_file", f"{k}={v}") for k, v in tables))
