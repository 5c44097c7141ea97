"""The loop as an SSP package (SSP 1.0 with FMI 2.0 FMUs, SSP 2.0 with FMI 3.0): `tiltload ssp export` and
`tiltload bundle` both write theirs here."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..user_error import UserError


def export(args: argparse.Namespace, out: Path, schedule: str | None = None):
    """The loop the options describe as an SSP package at out (SSP 2.0 when its FMUs are FMI 3.0): (path, SSP 2.0?,
    the schedule it is prepared for, the controller's loop delay in ticks or None, FMUs, stop time)."""
    from ....controller_fmu.design.cache import cache_root
    from ...engine.fmi.model_description import read_fmu
    from ...engine.ssp import export as ssp1
    from ...engine.ssp import ssp2
    from ..case.options import resolve_loop
    from ..case.system import build_system
    from ..loop.thesis import select_loop_delay

    if getattr(args, "input_file", ()):
        raise UserError("--input-file: an SSP package does not carry input files (give them to `tiltload run --system`)")
    loop = build_system(resolve_loop(args), cache_root() / "ssp")
    system, stop = loop.system, loop.stop
    _mission_inside(system, cache_root() / "ssp" / "missions")
    version2 = ssp2.needs_ssp2({i.name: read_fmu(i.fmu, i.name) for i in system.instances})
    schedule = schedule or ("ordered" if version2 else "jacobi")
    delay = select_loop_delay(system, schedule)
    try:
        path = (ssp2 if version2 else ssp1).export(system, out, stop, schedule)
    except OSError as err:
        raise UserError(f"cannot write {out}: {err.strerror or err}") from None
    return path, version2, schedule, delay, len(system.instances), stop


def loop_arguments(fmus: Path, fmi_version: int) -> argparse.Namespace:
    """The options of `tiltload ssp export --fmus FMUS --fmi N`, the defaults for the rest."""
    from .. import arguments

    p = argparse.ArgumentParser(prog="tiltload", allow_abbrev=False)
    arguments.add_loop_options(p)
    return p.parse_args(["--fmus", str(fmus), "--fmi", str(fmi_version)])


def _mission_inside(system, folder: Path) -> None:
    """A waypoint mission travels in the package: its knot file goes into a copy of the scenario FMU's resources/ folder
    and waypoints_file names it there (relative: the FMU reads it from its own resources), so another machine's libcosim
    or Ecos finds it (docs/test_bench.md, Missions in another FMI tool)."""
    import hashlib
    import zipfile

    scenario = next((i for i in system.instances if i.name == "scenario"), None)
    name = str(scenario.parameters.get("waypoints_file", "")) if scenario is not None else ""
    if not name or not Path(name).is_absolute():
        return
    knots = Path(name).read_bytes()
    member = f"mission-{hashlib.sha256(knots).hexdigest()[:20]}.csv"
    fmu = folder / member.removesuffix(".csv") / Path(scenario.fmu).name
    if not fmu.is_file():
        fmu.parent.mkdir(parents=True, exist_ok=True)
        partial = fmu.with_name(fmu.name + ".partial")
        with zipfile.ZipFile(scenario.fmu) as src, zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as out:
            for item in src.infolist():
                out.writestr(item, src.read(item.filename))
            out.writestr(zipfile.ZipInfo(f"resources/{member}", (1980, 1, 1, 0, 0, 0)), knots, zipfile.ZIP_DEFLATED)
        partial.replace(fmu)
    scenario.fmu = fmu
    scenario.parameters["waypoints_file"] = member
