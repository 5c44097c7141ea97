"""`tiltload bundle OUT.zip`: everything a user of another FMI tool needs, in one archive (as the Reference-FMUs'
release archive is): every FMU `tiltload build` makes, as FMI 2.0 and 3.0, each with binaries for the three
platforms; the loop as SSP 1.0 and 2.0 packages; the port contract in short (PORTS.txt) and a README.txt listing it.

The FMUs come from the same builds as `tiltload build --platforms linux64,win64,aarch64-linux --fmi 2|3` (into
--fmus, rebuilt only when stale), the packages from `tiltload ssp export`'s code: nothing is built a second way.
"""

from __future__ import annotations

import json
import tempfile
import zipfile
from pathlib import Path

from ..user_error import UserError

PLATFORMS = ("linux64", "win64", "aarch64-linux")  # every row of native_fmu.compile.TOOLCHAINS
FMI_VERSIONS = (2, 3)
SSP_PACKAGES = (("ssp/loop.ssp", 2, "SSP 1.0"), ("ssp/loop-fmi3.ssp", 3, "SSP 2.0"))

# The port contract in short (docs/ports.md says it in full); the lists below it are read from the FMUs themselves.
CONTRACT = """\
Timing: sample and hold on a 12 ms tick
  One tick is T_c = 12 ms; an FMU with period P (a whole number of ticks) steps doStep(t_k, P) at the ticks it is
  due. Within a tick: scenario -> sensors -> controller -> plant. The scenario, the sensors and the controller are
  sampling FMUs: doStep(t_k, h) computes their outputs from the inputs at t_k and holds them over [t_k, t_k + h).
  The plant integrates over [t_k, t_k + h) with its inputs held; its outputs after the call are the state at t_k + h.
  So the command u_k is computed from the measurement at t_k and applied over the same tick (no delay).

In another master (libcosim, Ecos, any Jacobi master at the 12 ms step)
  A Jacobi master passes an output to its inputs after every FMU stepped: a sampling FMU's outputs arrive one tick
  late, two ticks around the loop. The controller carries designs for a loop delay of 0, 1 and 2 ticks; its Integer
  parameter loop_delay_ticks picks one: 2 in a Jacobi master (ssp/loop.ssp sets it), 0 in tiltload's master.
  Ecos applies the SSP 1.0 package's parameter set only by name: init(parameter_set="initialValues").

A controller FMU of your own (in place of TiltloadController.fmu)
  Required outputs: f_R, f_L (N), tau_R, tau_L (N m), Real; the plant saturates them to 0..30 N and +-2 N m.
  Inputs: any subset of the names below, with these types; a name the contract lacks is refused (a misspelt port
  would sit at its start value). Its period is its DefaultExperiment stepSize, else 12 ms.
"""


def check_output(out: Path) -> Path:
    """The archive to write: a .zip that does not exist yet, in a folder that can be written (made if missing)."""
    out = Path(out)
    if out.suffix.lower() != ".zip":
        raise UserError(f"bundle: {out} must be a .zip file (e.g. tiltload-fmus.zip)")
    if out.exists() or out.is_symlink():
        raise UserError(f"bundle: {out} exists; remove it or name another file (a bundle never replaces one)")
    folder = out.parent if str(out.parent) else Path(".")
    blocking = next((f for f in (folder, *folder.parents) if f.exists()), None)
    if blocking is not None and not blocking.is_dir():
        raise UserError(f"bundle: cannot write {out}: {blocking} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UserError(f"bundle: cannot make the folder {folder}: {err.strerror or err}") from None
    probe = out.with_name(out.name + ".partial")
    try:  # a file made and removed: the only test a read-only file system or a root user cannot fool
        probe.open("xb").close()
        probe.unlink()
    except FileExistsError:
        raise UserError(f"bundle: {probe} exists (another bundle being written?); remove it") from None
    except OSError as err:
        raise UserError(f"bundle: cannot write in {folder}: {err.strerror or err}") from None
    return out


def toolchains():
    """The three platforms' toolchains; a missing compiler is the user's to install, named with its package."""
    from ....native_fmu.compile import BuildError, choose

    try:
        chosen, missing = choose()
    except BuildError as err:
        raise UserError(f"bundle: {err}") from None
    if missing:  # the default set leaves out what is not installed: a bundle needs all three
        raise UserError(f"bundle: it holds binaries for {', '.join(PLATFORMS)}, but {missing}")
    return chosen


def write(out: Path, fmus: Path, force: bool = False, progress=print) -> dict:
    """Build what is stale, export the SSP packages, and write the archive at out (whole or not at all); what it holds:
    {member: description}."""
    from ..loop.fmus import build_every
    from .ssp import export, loop_arguments

    out = check_output(out)
    chosen = toolchains()
    members: dict[str, Path] = {}
    for fmi in FMI_VERSIONS:
        for result in build_every(fmus, fmi, chosen, force, progress):
            members[f"fmi{fmi}/{result.path.name}"] = result.path
    with tempfile.TemporaryDirectory(prefix="tiltload_bundle_") as tmp:
        packages = {}
        for member, fmi, _ in SSP_PACKAGES:
            path, version2, schedule, delay, count, stop = export(loop_arguments(fmus, fmi), Path(tmp) / Path(member).name)
            members[member] = path
            packages[member] = (version2, schedule, delay, count, stop)
        descriptions = describe(members, packages)
        texts = {"README.txt": readme(descriptions), "PORTS.txt": ports_text(members["fmi2/TiltloadController.fmu"])}
        partial = out.with_name(out.name + ".partial")
        try:
            with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
                for name, text in texts.items():
                    z.writestr(name, text)
                for member, path in members.items():
                    z.write(path, member, zipfile.ZIP_STORED)  # FMUs and packages are zip files already
            partial.replace(out)
        except OSError as err:
            partial.unlink(missing_ok=True)
            raise UserError(f"bundle: cannot write {out}: {err.strerror or err}") from None
    return {**{"README.txt": "what the archive holds", "PORTS.txt": "the port contract"}, **descriptions}


def describe(members: dict[str, Path], packages: dict[str, tuple]) -> dict[str, str]:
    """One line per member, from the files themselves: an FMU's model description and its build record's platforms;
    refused if an FMU lacks a platform's binary (a bundle is for every platform)."""
    from ...engine.fmi.model_description import read_fmu

    out = {}
    for member, path in members.items():
        if member in packages:
            version2, schedule, delay, count, stop = packages[member]
            master = "tiltload's ordered master" if schedule == "ordered" else "a Jacobi master (libcosim, Ecos)"
            out[member] = (f"{'SSP 2.0, FMI 3.0' if version2 else 'SSP 1.0, FMI 2.0'}, {count} FMUs, {stop:g} s; for {master}: "
                           f"loop_delay_ticks {delay}")
            continue
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
            info = json.loads(z.read("resources/build_info.json"))
        md = read_fmu(path, path.stem)
        binaries = {n.split("/")[1] for n in names if n.startswith("binaries/") and n.count("/") >= 2 and not n.endswith("/")}
        wanted = set(info.get("platforms", ()))
        if len(binaries) < len(PLATFORMS) or not wanted <= binaries:
            raise UserError(f"bundle: {path} has binaries for {', '.join(sorted(binaries))} only; rebuild it: "
                            f"tiltload build --force --fmi {md.fmiVersion[0]} --platforms {','.join(PLATFORMS)}")
        clocks = (" (with FMI 3.0 clocks)" if path.stem.endswith("Clocked") else
                  " (FMI 3.0 Scheduled Execution)" if _is_scheduled(md) else "")
        out[member] = short(md.description or md.modelName, 84 - len(clocks)) + clocks
    return out


def _is_scheduled(md) -> bool:
    from ...engine.fmi.model_description import is_scheduled

    return is_scheduled(md)


def short(text: str, width: int = 84) -> str:
    """A model description's first clause, cut at a word to width."""
    first = text.split(": ")[0].split("; ")[0]
    return first if len(first) <= width else first[:width].rsplit(" ", 1)[0] + " ..."


def wrapped(head: str, words: list[str], width: int = 116) -> list[str]:
    import textwrap

    return textwrap.wrap(" ".join(words), width, initial_indent=head, subsequent_indent=" " * 6)


def readme(descriptions: dict[str, str]) -> str:
    from ....native_fmu.build import tiltload_version
    from ....native_fmu.compile import TOOLCHAINS

    lines = [f"tiltload {tiltload_version()}: the FMUs of a tilt-rotor UAV carrying a suspended load",
             "(Rego, MSc thesis, UFMG 2016), for any FMI 2.0 or 3.0 co-simulation tool.", "",
             "Every FMU is a co-simulation FMU (the *SE controllers: FMI 3.0 Scheduled Execution) with binaries for",
             "x86_64 Linux, x86_64 Windows and aarch64 Linux and its C sources. PORTS.txt says how the FMUs connect",
             "and what a controller of your own must declare.", ""]
    folders = {"fmi2": f"FMI 2.0; binaries/{', '.join(t.binary_folder(2) for t in TOOLCHAINS)}",
               "fmi3": f"FMI 3.0; binaries/{', '.join(t.binary_folder(3) for t in TOOLCHAINS)}",
               "ssp": "the load's loop as SSP packages, its FMUs inside"}
    width = max(len(Path(m).name) for m in descriptions)
    for folder, what in folders.items():
        lines.append(f"{folder}/  {what}")
        lines += [f"  {Path(m).name:<{width}}  {text}" for m, text in descriptions.items() if m.startswith(folder + "/")]
        lines.append("")
    lines += ["Run the loop: tiltload run --system ssp/loop-fmi3.ssp (or ssp/loop.ssp);",
              "libcosim: CosimExecution.from_ssp_file(\"ssp/loop.ssp\"); one FMU: fmpy simulate fmi2/TiltloadPlant.fmu",
              "Full documentation: docs/ in the tiltload source tree (ports.md, fmi3.md, platforms.md)."]
    return "\n".join(lines) + "\n"


def ports_text(controller_fmu: Path) -> str:
    """The contract in short, then the loop's connections and the controller's inputs as the FMUs declare them."""
    import numpy as np

    from ....native_fmu.build import tiltload_version
    from ....plant_fmu.vehicles import VEHICLES
    from ....sensor_fmu.suite import SUITES
    from ...engine.connections import resolve
    from ...engine.fmi.model_description import read_fmu
    from ...engine.system import System
    from ..loop.ports import contract_inputs
    from ..loop.thesis import default_system

    folder = Path(controller_fmu).parent
    system: System = default_system(folder)
    mds = {i.name: read_fmu(i.fmu, i.name) for i in system.instances}
    lines = [f"tiltload {tiltload_version()}: the port contract of the loop (in full: docs/ports.md)", "", CONTRACT]
    inputs = contract_inputs(np.zeros(VEHICLES["load"].nx), np.zeros(len(SUITES["load"].pi_names)), "load")
    by_kind: dict[str, list[str]] = {}
    for name, (kind, unit, _, _) in inputs.items():
        by_kind.setdefault(f"{kind}{f' ({unit})' if unit else ''}", []).append(name)
    for kind, names in by_kind.items():
        lines += wrapped(f"  {kind}: ", names)
    lines += ["", "The loop (stepping order; period)"]
    for inst in system.instances:
        period = inst.period or system.tick
        lines.append(f"  {inst.name:<11} {Path(inst.fmu).name:<26} every {period * 1e3:g} ms")
    lines += ["", "Connections (source -> target: variables)"]
    groups: dict[tuple[str, str], list[str]] = {}
    for link in resolve(system, mds):
        name = link.source_name if link.source_name == link.target_name else f"{link.source_name}->{link.target_name}"
        groups.setdefault((link.source, link.target), []).append(name)
    for (source, target), names in groups.items():
        lines += wrapped(f"  {source} -> {target} ({len(names)}): ", names)
    lines += ["", "Every FMU's variables, with types, units and descriptions: its modelDescription.xml."]
    return "\n".join(lines) + "\n"
