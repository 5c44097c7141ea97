"""The same FMUs in a native container: the fmu-manipulation-toolbox's container FMU, built from an ordered SSP package
and run by FMPy.

The toolbox's C runtime steps the embedded FMUs and copies values between them, with no interpreter in the loop. Three
things its SSP import does not carry over, which a like-for-like comparison needs (toolbox 2.0):
- the SSV parameter sets: each parameter becomes a start value of the container's configuration;
- the sequential schedule (`fmucontainer -sequential` is dropped for an .ssp, whose reader never passes it on): set on
  the assembly, with the FMUs in the package's order (scenario, sensors, controller, plant), which is how our ordered
  master steps them; in sequential mode each FMU gets the outputs the FMUs before it just computed;
- outputs: the plant's state is exposed, to compare the end of a run with ours.
(`-dump-json` also sorts the FMU list alphabetically, so a JSON round trip loses the order.) Built so, the container's
run is bit for bit ours over the same number of ticks: the container only steps while a whole tick fits in the
communication step, so a run to 20 s (1666.67 ticks) stops one tick before ours (1667 ticks, to the nearest tick).
"""

from __future__ import annotations

import logging
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import calloc, free
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)


@dataclass
class ContainerRun:
    wall: float  # seconds in the one doStep over the whole run
    cpu: float  # the process's CPU seconds in it
    outputs: np.ndarray  # the exposed outputs at the end, in the order asked for
    log: list[str]  # what the container said through the FMI logger


def _start_value(value) -> str | bool:
    if isinstance(value, bool):
        return value  # the toolbox writes a Python bool as true / false
    return repr(value) if isinstance(value, float) else str(value)


def build(package: Path, system, outputs: dict[str, list[str]], tick: float) -> Path:
    """The container FMU of an ordered package (next to it): system is the package loaded (ssp.load), for its order
    and parameters; outputs: {instance: [output names]} to expose as <instance>_<name>."""
    from fmu_manipulation_toolbox.assembly import Assembly

    quiet = logging.getLogger("fmu_manipulation_toolbox")
    level, quiet.level = quiet.level, logging.CRITICAL  # it warns of every unconnected port
    try:
        package = Path(package)
        assembly = Assembly(package.name, default_step_size=tick, default_auto_link=False, default_auto_input=False,
                            default_auto_output=False, fmu_directory=package.parent)
        node = assembly.root
        names = {Path(fmu).name: fmu for fmu in node.fmu_names_list}  # "<package>.dir/TiltloadPlant.fmu", ...
        by_instance = {i.name: names[Path(i.fmu).name] for i in system.instances}
        node.fmu_names_list = [by_instance[i.name] for i in system.instances]
        node.sequential = True
        for inst in system.instances:
            for key, value in inst.parameters.items():
                node.add_start_value(by_instance[inst.name], key, _start_value(value))
        for instance, ports in outputs.items():
            for port in ports:
                node.add_output(by_instance[instance], port, f"{instance}_{port}")
        assembly.make_fmu()
    finally:
        quiet.level = level
    return package.parent / node.name


def run(container: Path, ticks: int, tick: float, outputs: list[str]) -> ContainerRun:
    """Instantiate and initialize the container, then time one doStep over ticks * tick (the container steps every
    tick inside it); outputs are read at the end."""
    md = read_model_description(str(container))
    refs = {v.name: v.valueReference for v in md.modelVariables}
    folder = extract(str(container))
    said: list[str] = []

    def logger(env, inst, status, category, message):
        said.append(message.decode("utf-8", "replace"))
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(logger)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="container")
    try:
        slave.instantiate(callbacks=callbacks)
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        c0, t0 = time.process_time(), time.perf_counter()
        slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=ticks * tick)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        values = np.array(slave.getReal([refs[name] for name in outputs]))
        slave.terminate()
        slave.freeInstance()
        return ContainerRun(wall, cpu, values, said)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
