"""`tiltload ssp export`: the loop as an SSP 1.0 package that libcosim, Ecos and tiltload run; with FMI 3.0 FMUs
(--fmi 3, --clocks) an SSP 2.0 package (FMI 3.0 types and clocks) that tiltload runs."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments
from ..errors import UserError


def add_parser(sub) -> None:
    x = sub.add_parser("ssp", help="export the loop as an SSP package: SSP 1.0 (libcosim, Ecos, tiltload; docs/ports.md), or "
                                   "SSP 2.0 with --fmi 3 (docs/fmi3.md)")
    x.add_argument("action", choices=("export",), help="export: write the package")
    x.add_argument("out", type=Path, help="the package to write, e.g. loop.ssp")
    arguments.add_loop_options(x)
    x.add_argument("--schedule", choices=("jacobi", "ordered"), default=None,
                   help="the master the package is for: jacobi (libcosim, Ecos; the default for SSP 1.0) selects the designs "
                        "made for the 2-tick loop delay it adds; ordered (tiltload; the default for SSP 2.0) selects 0")
    x.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ....controller_fmu.design.cache import cache_root
    from ...engine import ssp, ssp2
    from ...engine.model_description import read_fmu
    from ..loop import select_loop_delay
    from ..options import loop_system, resolve_loop

    loop = loop_system(resolve_loop(args), cache_root() / "ssp")  # the one action, export (argparse checked it)
    system, stop = loop.system, loop.stop
    _mission_inside(system, cache_root() / "ssp" / "missions")
    version2 = ssp2.needs_ssp2({i.name: read_fmu(i.fmu, i.name) for i in system.instances})
    schedule = args.schedule or ("ordered" if version2 else "jacobi")
    delay = select_loop_delay(system, schedule)
    try:
        path = (ssp2 if version2 else ssp).export(system, args.out, stop, schedule)
    except OSError as err:
        raise UserError(f"cannot write {args.out}: {err.strerror or err}") from None
    print(f"{path}: SSP {'2.0' if version2 else '1.0'} package, {len(system.instances)} FMUs, {stop:g} s, prepared for a "
          f"{schedule} master" + (f"; the controller's designs for a {delay}-tick loop delay" if delay is not None else ""))
    others = ("" if version2 else f"   (libcosim: CosimExecution.from_ssp_file; Ecos: init(parameter_set='{ssp.PARAMETER_SET}'))")
    print(f"  run it: tiltload run --system {path}{others}")
    return 0


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
