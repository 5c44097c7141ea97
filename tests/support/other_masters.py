"""Runs an SSP package in libcosim or Ecos in a process of its own (libcosim aborts the process on a connector type it
does not know) and prints what the master logged as one JSON line: {"<instance>.<variable>": [[t, value], ...]}, or
{"error": the master's own message}.

    python other_masters.py libcosim|ecos PACKAGE STEP STEPS INSTANCE.VARIABLE:real|integer|boolean ...

libcosim: its time-series observer (real and integer samples at every step, t = 0 included) and its file observer
(booleans, written 0/1); Ecos: its getters after init and after every step. Ecos applies the parameter set named
PARAMETER_SET (master/engine/ssp/schema.py); libcosim applies every parameter binding."""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

PARAMETER_SET = "initialValues"


def libcosim(package: str, step: float, steps: int, variables: list[tuple[str, str, str]]) -> dict:
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution, get_last_error_message  # libcosim's own message
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    nanoseconds = round(step * 1e9)
    try:
        ex = CosimExecution.from_ssp_file(package, step_size=nanoseconds)
    except AssertionError:
        return {"error": get_last_error_message()}
    index = {s.name.decode(): s.index for s in ex.slave_infos()}
    refs = {(name, v.name.decode()): v.reference for name, i in index.items() for v in ex.slave_variables(i)}
    series = CosimObserver.create_time_series()
    ex.add_observer(series)
    kinds = {"real": CosimVariableType.REAL, "integer": CosimVariableType.INTEGER}
    for instance, name, kind in variables:
        if kind in kinds:
            series.start_time_series(index[instance], refs[instance, name], kinds[kind])
    folder = Path(tempfile.mkdtemp(prefix="libcosim_csv_"))
    ex.add_observer(CosimObserver.create_to_dir(str(folder)))
    if not ex.simulate_until(steps * nanoseconds):
        return {"error": get_last_error_message()}
    del ex  # the file observer's files are complete once the execution is gone
    out = {}
    for instance, name, kind in variables:
        if kind == "boolean":
            (csv,) = folder.glob(f"{instance}_*.csv")
            lines = csv.read_text().splitlines()
            column = lines[0].split(",").index(name)
            out[f"{instance}.{name}"] = [[float(line.split(",")[0]), bool(int(line.split(",")[column]))]
                                         for line in lines[1:]]
            continue
        read = series.time_series_real_samples if kind == "real" else series.time_series_integer_samples
        times, _, values = read(index[instance], refs[instance, name], 0, steps + 1)
        out[f"{instance}.{name}"] = [[t / 1e9, v] for t, v in zip(times, values)]
    return out


def ecos(package: str, step: float, steps: int, variables: list[tuple[str, str, str]]) -> dict:
    from ecospy import EcosSimulation

    try:
        sim = EcosSimulation(ssp_path=package, step_size=step)
    except Exception as err:  # ecospy raises a bare Exception with the library's message
        return {"error": str(err)}
    out: dict = {}
    try:
        if not sim.init(parameter_set=PARAMETER_SET):
            return {"error": "init failed"}
        for k in range(steps + 1):
            if k:
                sim.step(1)
            t = sim.get_time()
            for instance, name, kind in variables:
                get = {"real": sim.get_real, "integer": sim.get_integer, "boolean": sim.get_bool}[kind]
                out.setdefault(f"{instance}.{name}", []).append([t, get(f"{instance}::{name}")])
    finally:
        sim.terminate()
        sim.free()
    return out


if __name__ == "__main__":
    tool, package, step, steps, *names = sys.argv[1:]
    variables = [(*spec.rsplit(":", 1)[0].split(".", 1), spec.rsplit(":", 1)[1]) for spec in names]
    result = (libcosim if tool == "libcosim" else ecos)(package, float(step), int(steps), variables)
    print(json.dumps(result))
