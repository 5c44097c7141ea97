"""Argument types of the `tiltload` command and the options that describe a run of the loop."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..command_line.argument_types import DAY, integer, positive_number, positive_time, run_time, time_span, tolerance
from ..command_line.path_types import existing_folder, folder, kind, output_file
from .case.fields import CASE, MAX_REALTIME_FACTOR, assignment, expected_fmu, file_stem, realtime_factor, whole_number
from .loop import defaults

# the checks are the engine's (one implementation, shared with tiltload serve) and the case core's (case/fields.py: the
# API checks its fields by the same types); the commands find them here
__all__ = ["DAY", "MAX_REALTIME_FACTOR", "assignment", "existing_folder", "expected_fmu", "file_stem", "folder", "integer",
           "output_file", "positive_number", "positive_time", "realtime_factor", "run_time", "time_span", "tolerance",
           "whole_number"]

DEFAULT_FMU_DIR = defaults.FMU_DIR  # the commands' --fmus


def controller(text: str) -> str:
    """dlqr, mixed, an existing controller FMU file or a controller class's .py file (the --controller of a side of
    b2b)."""
    if text in ("dlqr", "mixed") or (text.endswith((".fmu", ".py")) and Path(text).is_file()):
        return text
    if text.endswith(".py"):
        raise argparse.ArgumentTypeError(f"controller {text} does not exist" if not Path(text).exists() else
                                         f"controller {text} is {kind(Path(text))}, not a Python file")
    if text.endswith(".fmu"):
        raise argparse.ArgumentTypeError(f"controller {text} does not exist" if not Path(text).exists() else
                                         f"controller {text} is {kind(Path(text))}, not an FMU file")
    raise argparse.ArgumentTypeError(f"{text!r} is neither dlqr, mixed, an existing FMU file nor a class's .py file")


def add_loop_options(p: argparse.ArgumentParser) -> None:
    """What describes a run of the loop: shared by run and ssp export (resolved by options.resolve_loop). The loop's
    own options default to None (False for flags), so that resolve_loop knows which were given: with --system they
    are refused, not ignored."""
    p.add_argument("--vehicle", **CASE.option("vehicle"), default=None,
                   help="load: the UAV with its suspended load (ch. 5, default); uav: the UAV alone (Appendix A)")
    p.add_argument("--scenario", **CASE.option("scenario"), default=None, help=f"estimation scenario (default {defaults.SCENARIO})")
    p.add_argument("--trajectory", default=None, metavar="N|SHAPE|FILE",
                   help="load: 1 circle (default), 2 Table 5.3; uav: 3 Appendix A's circle (default); 0 hover; a shape "
                        "(lemniscate, lissajous, step-x/y/z, ramp-x/y/z, with :KEY=VALUE,... e.g. step-z:size=0.5); or a "
                        "waypoint file (CSV t,x,y,z[,psi], JSON/YAML): docs/test_bench.md")
    p.add_argument("--wind", type=Path, default=None, metavar="FILE",
                   help="wind on the load: steady, Dryden turbulence, a profile (YAML/JSON, or a CSV profile t,x,y,z); "
                        "seeded by --seed; docs/test_bench.md")
    p.add_argument("--allow-infeasible", action="store_true",
                   help="run a reference the actuators cannot follow (Table 5.2), with a warning instead of refusing it")
    p.add_argument("--max-tilt", **CASE.option("max_tilt"), default=defaults.MAX_TILT, metavar="DEG",
                   help="largest trim tilt angle the feasibility check accepts (default 30 degrees)")
    p.add_argument("--controller", default=None,
                   help="dlqr, mixed (the load's default; the UAV alone has dlqr), PATH.fmu of your own controller, or "
                        "PATH.py of a controller class (run: wrapped on the fly, natively where it traces; docs/ports.md)")
    p.add_argument("--seed", **CASE.option("seed"), default=None, help="noise seed, 0 .. 2147483647 (default 1)")
    p.add_argument("--stop-time", **CASE.option("stop_time"), default=None, help="s (default: the trajectory's duration; at most 1e6)")
    p.add_argument("--delay", action="store_true", help="one-tick actuation delay (controller -> plant)")
    p.add_argument("--no-gusts", action="store_true", help="no wind gusts")
    p.add_argument("--faults", type=Path, default=None, metavar="FILE",
                   help="a fault schedule (JSON/YAML, or a libcosim scenario): docs/faults.md")
    p.add_argument("--set", **CASE.option("set"), action="append", default=[], metavar="INSTANCE.NAME=VALUE",
                   help="set an FMU parameter, e.g. --set plant.m_L=0.2 (repeatable)")
    p.add_argument("--system", type=Path, default=None,
                   help="an SSP package (.ssp/.ssd) or a JSON system description instead of the loop (the loop's options "
                        "--vehicle, --scenario, --trajectory, --controller, --seed, --delay, --no-gusts, --fmus do "
                        "not apply to it; --faults, --set and --stop-time do)")
    p.add_argument("--input-file", **CASE.option("input_file"), action="append", default=[], metavar="INSTANCE=FILE",
                   help="--system: a CSV or Parquet table of that instance's inputs over time (first column time), as "
                        "FMPy's --input-file: continuous inputs interpolated, discrete ones held; repeatable")
    p.add_argument("--step", **CASE.option("step"), default=None, metavar="S",
                   help="--system: the step of an SSP package that declares none (default: the smallest of its FMUs' "
                        "DefaultExperiment step sizes)")
    p.add_argument("--start-time", **CASE.option("start_time"), default=None, metavar="S",
                   help="--system: the time the system starts at (default: its file's, else 0); the FMUs are set up "
                        "there and --stop-time is an absolute time, as FMPy's")
    p.add_argument("--allow-external-fmus", action="store_true",
                   help="--system: let a component's FMU lie outside the package or the system file's folder")
    p.add_argument("--fmus", **CASE.option("fmus"), default=None, help="FMU folder (default: fmus)")
    p.add_argument("--fmi", type=int, **CASE.option("fmi"), default=None,
                   help="the loop's FMUs as FMI 2.0 (default; in FMUS/) or FMI 3.0 co-simulation FMUs (in FMUS/fmi3/)")
    p.add_argument("--clocks", action="store_true",
                   help="with --fmi 3: the sensors and the controller with FMI 3.0 clocks, which replace their periods "
                        "(default: the plain FMI 3.0 FMUs, which every FMI 3.0 importer runs; docs/fmi3.md)")
    p.add_argument("--allow-unknown-inputs", action="store_true",
                   help="accept a controller FMU whose inputs include names the port contract does not have")
    p.add_argument("--remote", **CASE.option("remote"), action="append", default=[], metavar="INSTANCE=HOST:PORT",
                   help="run that instance's FMU on the tiltload serve at HOST:PORT (the same FMU, picked there by model "
                        "identifier and GUID; docs/remote.md); repeatable")
