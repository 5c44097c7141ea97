"""Generated bad input: every one gets one line and a non-zero exit, never a traceback."""

from __future__ import annotations

import copy
import hashlib
import json
import os
import re
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
from support.fmi2_session import wrap_misbehaving
from support.isolated_case import command_exit_code
from tiltload.master.app.cli import main

BAD_NUMBERS = ["x", "", "nan", "inf", "-inf", "-1", "0", "1e400", "0x10", "1,5", "--", "None", "true"]


EXCEPTION_NAME = re.compile(r"\b[A-Z][A-Za-z]*(Error|Exception|Exit|Interrupt)\b\s*:")  # Python's "TypeError: ..." form


def exit_code(argv: list[str]) -> int | None:
    """The command's exit code, the command run as `tiltload` runs, each case in a session of its own with TMPDIR a
    fresh empty folder (support/isolated_case.py); a file it left there, a process of its group alive after it, or a
    hang is one more line on stderr, which each loop's one-line check reports with the case's label."""
    return command_exit_code(argv)


def _cli_cases() -> list[tuple[str, list[str]]]:
    cases = []
    run = ["run", "--stop-time", "0.1", "--quiet", "--no-plots"]
    for value in ["x", "", "-1", "2147483648", "4294967297", "1.5", "nan", "1e3", "0x1", "1 2"]:
        cases.append((f"seed={value!r}", [*run, "--seed", value]))
    for value in BAD_NUMBERS:
        cases.append((f"stop-time={value!r}", ["run", "--quiet", "--no-plots", "--stop-time", value]))
        cases.append((f"step-timeout={value!r}", [*run, "--step-timeout", value]))
    for value in ["3", "-1", "1.5", "x", str(2**40), ""]:
        cases.append((f"trajectory={value!r}", [*run, "--trajectory", value]))
    for value in ["FSI", "ekf", "", "zse,lkf"]:
        cases.append((f"scenario={value!r}", [*run, "--scenario", value]))
    for value in ["0", "-1", "x", "1.5", ""]:
        cases.append((f"log-every={value!r}", [*run, "--log-every", value]))
    for value in ["../x", "a/b", "", ".", "..", "x\ny", "/abs"]:
        cases.append((f"name={value!r}", [*run, "--name", value]))
    for value in ["pid", "missing.fmu", "", "dlqr.fmu", "/"]:
        cases.append((f"controller={value!r}", [*run, "--controller", value]))
    for flag in ["--bogus", "--seed", "--stop-time", "--set", "-x"]:
        cases.append((f"flag {flag}", [*run, flag]))
    for command in [[], ["bogus"], ["run", "extra"], ["compare"], ["compare", "a"], ["plot"], ["wrap"], ["campaign"]]:
        cases.append((f"command {command}", command))
    for value in ["0", "-0.012", "x", "nan", "inf"]:
        cases.append((f"design Tc={value!r}", ["design", "--Tc", value]))
    cases.append(("design pid", ["design", "--controller", "pid"]))
    for value in ["nan", "-1", "inf", "x", "-inf"]:
        cases.append((f"compare rtol={value!r}", ["compare", "a.mcap", "b.json", "--rtol", value]))
        cases.append((f"compare atol={value!r}", ["compare", "a.mcap", "b.json", "--atol", value]))
    for value in ["0", "-1", "x"]:
        cases.append((f"campaign workers={value!r}", ["campaign", "spec.toml", "--workers", value]))
    return cases


def _set_cases() -> list[tuple[str, list[str]]]:
    run = ["run", "--stop-time", "0.1", "--quiet", "--no-plots", "--no-log"]
    sets = ["plant", "=1", "plant.=1", ".m_L=1", "plant.m_L", "nobody.m_L=1", "plant.nothing=1", "plant.x=1",
            "plant.m_L=nan", "plant.m_L=inf", "plant.m_L=abc", "plant.m_L=-1", "plant.m_L=0", "plant.g=-inf",
            "sensors.seed=-1", "sensors.seed=2147483648", "sensors.seed=x", "sensors.seed=1.5",
            "scenario.trajectory=9", "scenario.trajectory=4", "scenario.trajectory=-1", "scenario.trajectory=x", "scenario.gusts=maybe",
            "controller.controller=pid", "controller.estimator=ekf", "controller.controller=1",
            "plant.servo_R_stuck=maybe", "plant.f_R=1", "sensors.gps_x=1", "plant.x_0=nan", "plant.z_0=1e400"]
    return [(f"set {s!r}", [*run, "--set", s]) for s in sets]


def _spare_row(name: str) -> bool:
    """A row of the scenario's wind-profile table other than the first and the last: the same check as theirs (hundreds
    of runs for nothing)."""
    m = re.fullmatch(r"(wind_profile_[txyz])_(\d+)", name)
    return m is not None and int(m.group(2)) not in (0, 63)


def _parameter_cases(fmus: Path) -> list[tuple[str, list[str]]]:
    """Every parameter of the four FMUs, given values of the wrong kind or out of range."""
    from fmpy import read_model_description

    run = ["run", "--stop-time", "0.1", "--quiet", "--no-plots", "--no-log"]
    bad = {"Real": ["nan", "-inf", "abc"], "Integer": ["1.5", "abc", "99999999999"], "Boolean": ["maybe", "2"],
           "String": ["", "bogus"]}
    cases = []
    for instance, fmu in (("scenario", "TiltloadScenario"), ("sensors", "TiltloadSensors"), ("controller", "TiltloadController"),
                          ("plant", "TiltloadPlant")):
        md = read_model_description(str(fmus / f"{fmu}.fmu"))
        for v in md.modelVariables:
            if v.causality == "parameter" and not _spare_row(v.name):
                values = ["bogus", "/dev/null"] if v.name == "waypoints_file" else bad[v.type]  # "" is its default: none
                cases += [(f"set {instance}.{v.name}={value!r}", [*run, "--set", f"{instance}.{v.name}={value}"])
                          for value in values]
    return cases


def _valid_system(fmus: Path) -> dict:
    return {"tick": 0.012, "auto_connect": True, "instances": [
        {"name": "scenario", "fmu": str(fmus / "TiltloadScenario.fmu"), "parameters": {"trajectory": 1}},
        {"name": "sensors", "fmu": str(fmus / "TiltloadSensors.fmu"), "parameters": {"seed": 1}},
        {"name": "controller", "fmu": str(fmus / "TiltloadController.fmu"),
         "parameters": {"controller": "mixed", "estimator": "zse"}},
        {"name": "plant", "fmu": str(fmus / "TiltloadPlant.fmu"), "timing": "continuous"}],
        "connections": [{"source": "controller.f_R", "target": "plant.f_R", "delay": 0}]}


def _system_mutations() -> list[tuple[str, object]]:
    """(label, function of a valid description -> a broken one)."""
    def setter(path, value):
        def apply(d):
            target = d
            for key in path[:-1]:
                target = target[key]
            target[path[-1]] = value
            return d
        return apply

    def deleter(path):
        def apply(d):
            target = d
            for key in path[:-1]:
                target = target[key]
            del target[path[-1]]
            return d
        return apply

    out = []
    for value in [0, -0.012, "0.012", True, None, [], {}, float("inf"), 1e308, 7200]:
        out.append((f"tick={value!r}", setter(["tick"], value)))
    for value in ["false", "no", 0, 1, None, [], "true"]:
        out.append((f"auto_connect={value!r}", setter(["auto_connect"], value)))
    for key in ["conections", "paramters", "Tick", "instance", "fault"]:
        out.append((f"unknown key {key}", setter([key], [])))
    for key in ["tick", "instances"]:
        out.append((f"no {key}", deleter([key])))
    for value in [[], {}, "plant", None, [1], [[]]]:
        out.append((f"instances={value!r}", setter(["instances"], value)))
    for value in ["", "1plant", "my plant", "a.b", "x\ny", "\u0000", None, 3, "ü"]:
        out.append((f"instance name {value!r}", setter(["instances", 3, "name"], value)))
    out.append(("duplicate instance name", setter(["instances", 1, "name"], "scenario")))
    for value in ["", None, 3, "missing.fmu", "/", "."]:
        out.append((f"instance fmu {value!r}", setter(["instances", 3, "fmu"], value)))
    for value in [0, -0.012, 0.018, "0.024", True, float("nan")]:
        out.append((f"period {value!r}", setter(["instances", 2, "period"], value)))
    for value in ["discrete", "", None, 1]:
        out.append((f"timing {value!r}", setter(["instances", 3, "timing"], value)))
    for key, value in [("m_L", None), ("m_L", [1]), ("m_L", {}), ("no such", 1), ("", 1), ("nothing", 1), ("m_L", "heavy")]:
        out.append((f"plant parameter {key!r}={value!r}", setter(["instances", 3, "parameters"], {key: value})))
    out.append(("parameters a list", setter(["instances", 3, "parameters"], [1])))
    out.append(("unknown instance key", setter(["instances", 3, "priority"], 1)))
    for key, value in [("source", "nobody.f_R"), ("source", "controller"), ("target", "plant.nothing"), ("source", ""),
                       ("target", "plant f_R"), ("delay", 1.5), ("delay", True), ("delay", -1), ("delay", "1"), ("delay", 10**6),
                       ("source", "controller.nothing"), ("extra", 1)]:
        out.append((f"connection {key}={value!r}", setter(["connections", 0, key], value)))
    out.append(("connection without target", deleter(["connections", 0, "target"])))
    for value in ["x", {}, [1], [{"at": "plant.f_R"}], [{"target": "plant.f_R", "kind": "explode"}]]:
        out.append((f"faults={value!r}"[:40], setter(["faults"], value)))
    return out


def _files(folder: Path, fmus: Path, misbehaving: dict[str, Path]) -> list[tuple[str, list[str]]]:
    """Broken files of every kind, each fed to the command that reads it."""
    cases = []
    run = ["run", "--stop-time", "0.1", "--quiet", "--no-plots", "--fmus", str(fmus), "--out", str(folder / "runs")]
    valid = _valid_system(fmus)
    for i, (label, mutate) in enumerate(_system_mutations()):
        path = folder / f"system_{i}.json"
        path.write_text(json.dumps(mutate(copy.deepcopy(valid))))
        cases.append((f"system {label}", [*run, "--system", str(path)]))
    raw = {"empty": b"", "truncated": b'{"tick": 0.012, "instances": [', "binary": bytes(range(256)), "yaml": b"tick: 0.012\n",
           "list": b"[]", "number": b"12", "nul": b'{"tick": 0.012\x00}', "latin1": '{"tick": "é"}'.encode("latin-1")}
    for label, data in raw.items():
        path = folder / f"raw_{label}.json"
        path.write_bytes(data)
        cases.append((f"system file {label}", [*run, "--system", str(path)]))
    cases.append(("system file missing", [*run, "--system", str(folder / "nope.json")]))
    cases.append(("system file is a folder", [*run, "--system", str(folder)]))

    controller = fmus / "TiltloadController.fmu"
    fmu_files = {"text": None, "empty": None, "zip without description": {}, "broken xml": {"modelDescription.xml": b"<fmi"},
                 "not xml": {"modelDescription.xml": b"\x00\x01"}}
    for label, members in fmu_files.items():
        path = folder / f"{label.replace(' ', '_')}.fmu"
        if members is None:
            path.write_bytes(b"" if label == "empty" else b"not an FMU")
        else:
            with zipfile.ZipFile(path, "w") as z:
                for name, data in members.items():
                    z.writestr(name, data)
        cases.append((f"controller FMU: {label}", [*run, "--controller", str(path)]))

    def edited(label, edit):
        path = folder / f"edited_{len(cases)}.fmu"
        with zipfile.ZipFile(controller) as src, zipfile.ZipFile(path, "w") as out:
            for item in src.infolist():
                data = src.read(item.filename)
                if item.filename == "modelDescription.xml":
                    data = edit(data.decode()).encode()
                if item.filename != "resources/build_info.json":
                    out.writestr(item, data)
        cases.append((f"controller FMU: {label}", [*run, "--controller", str(path)]))

    edited("model exchange only", lambda x: x.replace("<CoSimulation", "<ModelExchange").replace("</CoSimulation", "</ModelExchange"))
    edited("FMI 3.0", lambda x: x.replace('fmiVersion="2.0"', 'fmiVersion="3.0"'))
    edited("FMI 1.0", lambda x: x.replace('fmiVersion="2.0"', 'fmiVersion="1.0"'))
    edited("unknown input name", lambda x: x.replace('name="x_ref"', 'name="ref_x"'))
    edited("no f_R output", lambda x: x.replace('name="f_R"', 'name="thrust_right"'))
    edited("wrong model identifier", lambda x: x.replace('modelIdentifier="', 'modelIdentifier="Other'))
    edited("wrong GUID", lambda x: re.sub(r'guid="\{[^}]*\}"', 'guid="{00000000-0000-0000-0000-000000000000}"', x))
    edited("step size not a tick multiple", lambda x: re.sub(r'stepSize="[^"]*"', 'stepSize="0.018"', x))
    for mode, fmu in misbehaving.items():
        cases.append((f"controller FMU that misbehaves: {mode}", [*run, "--stop-time", "1", "--step-timeout", "1",
                                                                    "--controller", str(fmu)]))

    faults = {"missing": None, "not json": b"{", "unknown target": b'[{"target": "plant.nothing", "kind": "bias", "value": 1}]',
              "unknown kind": b'[{"target": "plant.x", "kind": "explode"}]', "negative start": b'[{"target": "plant.x", "kind": '
              b'"bias", "value": 1, "start": -1}]', "nan value": b'[{"target": "plant.x", "kind": "bias", "value": NaN}]',
              "no instance": b'[{"target": "nobody.x", "kind": "bias", "value": 1}]', "object": b'{"target": "plant.x"}',
              "unknown variable": b'{"faults": [{"action": "bias", "targets": ["plant.nothing"], "value": 1, "start": 0}]}',
              "unknown instance": b'{"faults": [{"action": "bias", "targets": ["nobody.x"], "value": 1, "start": 0}]}',
              "a parameter": b'{"faults": [{"action": "bias", "targets": ["plant.m_L"], "value": 1, "start": 0}]}',
              "bias on a Boolean": b'{"faults": [{"action": "bias", "targets": ["sensors.gps_new"], "value": 1, "start": 0}]}'}
    for label, data in faults.items():
        path = folder / f"faults_{label.replace(' ', '_')}.json"
        if data is not None:
            path.write_bytes(data)
        cases.append((f"faults {label}", [*run, "--faults", str(path)]))

    specs = {"missing": None, "empty": b"", "not toml": b"[[[", "unknown key": b'name = "x"\nbogus = 1\n',
             "bad runs": b'name = "x"\nruns = -1\n', "unknown parameter": b'name = "x"\n[vary]\n"plant.nothing" = [1, 2]\n'}
    for label, data in specs.items():
        path = folder / f"spec_{label.replace(' ', '_')}.toml"
        if data is not None:
            path.write_bytes(data)
        cases.append((f"campaign spec {label}", ["campaign", str(path), "--fmus", str(fmus), "--out", str(folder / "camp")]))
    cases.append(("campaign report of a missing file", ["campaign", "report", str(folder / "nope.parquet")]))
    cases.append(("campaign report of a text file", ["campaign", "report", str(folder / "raw_yaml.json")]))

    baselines = {"empty": b"", "no metrics": b'{"tolerances": {}}', "empty metrics": b'{"metrics": {}}',
                 "string metric": b'{"metrics": {"ISE(x)": "a"}}', "nan metric": b'{"metrics": {"ISE(x)": NaN}}',
                 "list": b"[1]", "negative tolerance": b'{"metrics": {"ISE(x)": 1}, "tolerances": {"rtol": -1}}',
                 "infinite tolerance": b'{"metrics": {"ISE(x)": 1}, "tolerances": {"atol": Infinity}}',
                 "string tolerance": b'{"metrics": {"ISE(x)": 1}, "tolerances": {"rtol": "1"}}'}
    some_log = folder / "corrupt.mcap"
    some_log.write_bytes(b"\x89MCAP0\r\n" + bytes(200))
    for label, data in baselines.items():
        path = folder / f"baseline_{label.replace(' ', '_')}.json"
        path.write_bytes(data)
        cases.append((f"compare baseline {label}", ["compare", str(some_log), str(path)]))
    for label, path in {"missing log": folder / "nope.mcap", "text log": folder / "raw_yaml.json",
                        "corrupt log": some_log, "empty log": folder / "empty.fmu"}.items():
        cases.append((f"compare {label}", ["compare", str(path), str(folder / "baseline_nan_metric.json")]))
        cases.append((f"plot {label}", ["plot", str(path), "--out", str(folder / "plots")]))
    # issue 51: signals in tolerance tubes (the tolerance file is read first, then the baseline, then the run)
    (folder / "fake.parquet").write_bytes(b"PAR1 not a parquet file PAR1")
    tolerance_files = {"negative": b"[default]\nabs = -1\n", "infinite": b'[signals."plant.x"]\nlag = inf\n',
                       "unknown key": b"[default]\nabsolute = 1\n", "not instance.variable": b"[signals.x]\nabs = 1\n",
                       "extra table": b"[defaults]\nabs = 1\n"}
    for label, data in tolerance_files.items():
        path = folder / f"tolerances_{label.replace(' ', '_').replace('.', '_')}.toml"
        path.write_bytes(data)
        cases.append((f"compare tolerances {label}", ["compare", str(some_log), str(folder / "fake.parquet"), "--tolerances", str(path)]))
    cases += [("compare signal baseline missing", ["compare", str(some_log), str(folder / "nope.parquet")]),
              ("compare signal baseline not parquet", ["compare", str(some_log), str(folder / "fake.parquet")]),
              ("compare --signals empty", ["compare", str(some_log), str(some_log), "--signals", ","]),
              ("compare --lead negative", ["compare", str(some_log), str(some_log), "--lead", "-0.1"]),
              ("compare --abs inf", ["compare", str(some_log), str(some_log), "--abs", "inf"])]
    for label, source in {"missing": folder / "nope.py", "not python": folder / "raw_binary.json",
                          "no class": folder / "noclass.py", "syntax error": folder / "syntax.py"}.items():
        if label == "no class":
            source.write_text("x = 1\n")
        if label == "syntax error":
            source.write_text("class C(:\n")
        cases.append((f"wrap {label}", ["wrap", str(source), "--out", str(folder / "w.fmu")]))
    return cases


# ---- issue 37, the input layer: waypoint, wind, fault and campaign files (engine/user_files.py) ----------------------

def _yaml_bomb(levels: int = 9) -> str:
    lines = ["a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    return "\n".join(lines + [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, levels)]) + "\n"


def _scenario_file_cases(folder: Path) -> list[tuple[str, list[str]]]:
    """Every kind of file given to --trajectory, --wind, --faults and `campaign`, broken in the ways that cost (bombs,
    spans, digits, widths) and the ways that are plain wrong (types, ranges, encodings)."""
    run = ["run", "--stop-time", "0.1", "--quiet", "--no-plots", "--no-log"]
    wp = "t,x,y,z\n0,0,0,1\n"
    common = {  # any file: unreadable as text, or bounded before it is read
        "binary": bytes(range(256)), "nul": b"t,x,y,z\n0,0,0,1\x00\n", "latin1": "t,x\n0,\xe9\n".encode("latin-1"),
        "bom only": b"\xef\xbb\xbf", "too large": b"#" * (17 * 2**20),
    }
    trajectory = {
        **{f"csv {k}": v for k, v in common.items()},
        "csv far end": wp + "1e9,1,0,1\n", "csv close": wp + "1e-300,1,0,1\n", "csv 1e-4 apart": wp + "0.0001,1,0,1\n",
        "csv wide cell": wp + "5," + "1" * 140_000 + ",0,1\n", "csv 400 digits": wp + "5," + "1" * 400 + ",0,1\n",
        "csv x 1e300": wp + "5,1e300,0,1\n", "csv psi huge": "t,x,y,z,psi\n0,0,0,1,0\n5,0,0,1,1e6\n",
        "csv vx huge": "t,x,y,z,vx\n0,0,0,1,0\n5,0,0,1,1e9\n", "csv quote": wp + '5,"1,0,1\n',
        "csv 10001 waypoints": "t,x,y,z\n" + "".join(f"{k * 0.5},0,0,1\n" for k in range(10_001)),
        "csv header only": "t,x,y,z\n", "csv t hex": wp + "0x5,1,0,1\n",
        "yaml bomb": _yaml_bomb(), "yaml alias": "a: &w {t: 0, x: 0, y: 0, z: 1}\nwaypoints: [*w, *w]\n",
        "yaml 400 digits": "waypoints:\n  - {t: 0, x: 0, y: 0, z: 1}\n  - {t: 5, x: " + "9" * 400 + ", y: 0, z: 1}\n",
        "yaml date": "waypoints:\n  - {t: 2020-01-01, x: 0, y: 0, z: 1}\n  - {t: 5, x: 1, y: 0, z: 1}\n",
        "yaml int keys": "waypoints:\n  - {1: 0, x: 0, y: 0, z: 1}\n", "yaml deep": "waypoints: " + "[" * 200 + "]" * 200 + "\n",
        "yaml shape far": "shape: lissajous\nduration: 1.0e+9\n", "yaml shape huge": "shape: lemniscate\nsize_x: 1.0e+300\n",
        "json 400 digits": '{"waypoints": [{"t": 0, "x": 0, "y": 0, "z": 1}, {"t": ' + "1" * 400 + ', "x": 1, "y": 0, "z": 1}]}',
        "json 1e400": '{"waypoints": [{"t": 0, "x": 0, "y": 0, "z": 1}, {"t": 5, "x": 1e400, "y": 0, "z": 1}]}',
        "json deep": '{"waypoints": ' + "[" * 100_000 + "]" * 100_000 + "}",
        "json waypoints object": '{"waypoints": {"t": 0}}', "json waypoint list": '{"waypoints": [[0, 0, 0, 1], [5, 1, 0, 1]]}',
    }
    wind = {
        **{f"csv {k}": v for k, v in common.items()},
        "yaml bomb": _yaml_bomb(), "yaml steady 1e300": "steady: [1.0e+300, 0, 0]\n", "json steady 1e300": '{"steady": [1e300, 0, 0]}',
        "json 400 digits": '{"steady": [' + "1" * 400 + ", 0, 0]}", "json NaN": '{"steady": [NaN, 0, 0]}',
        "csv profile far": "t,x,y,z\n0,0,0,0\n1e9,1,0,0\n", "csv profile 1e300": "t,x,y,z\n0,1e300,0,0\n",
        "csv wide cell": "t,x,y,z\n0," + "1" * 140_000 + ",0,0\n", "yaml airspeed huge": "dryden: {severity: light, airspeed: 1.0e+9}\n",
        "yaml drag huge": "drag_area: 1.0e+9\n", "json deep": '{"profile": ' + "[" * 100_000 + "]" * 100_000 + "}",
    }
    faults = {"yaml bomb": _yaml_bomb(), "json 400 digits": '[{"target": "plant.x", "kind": "bias", "value": ' + "1" * 400 + "}]",
              "json deep": "[" * 100_000 + "]" * 100_000, "binary": bytes(range(256)), "too large": b" " * (17 * 2**20)}
    values = ", ".join(str(0.1 + k / 100) for k in range(20))
    grid = "".join(f'[[vary.parameters]]\nname = "p{i}"\ntargets = ["plant.m_L"]\nvalues = [{values}]\n' for i in range(8))
    specs = {"yaml bomb": ("yaml", "name: x\n" + _yaml_bomb()), "grid": ("toml", f'name = "g"\n[base]\nscenario = "zse"\n[vary]\n{grid}'),
             "samples": ("toml", 'name = "g"\n[base]\nscenario = "zse"\ncontrollers = ["dlqr", "mixed"]\n[vary]\nmethod = "lhs"\n'
                                 'samples = 100000\nseeds = [1, 2]\n[[vary.parameters]]\nname = "m"\ntargets = ["plant.m_L"]\n'
                                 'range = [0.1, 0.2]\n'),
             "toml nan": ("toml", 'name = "x"\n[base]\nmax_tilt = nan\n'), "yaml deep": ("yaml", "name: " + "[" * 300 + "]" * 300 + "\n"),
             "binary": ("toml", bytes(range(256))),
             "trajectory bomb": ("toml", 'name = "x"\n[base]\ntrajectory = "bomb.yaml"\n[vary]\nseeds = [1]\n'),
             "wind 1e300": ("toml", 'name = "x"\n[base]\nwind = "wind.json"\n[vary]\nseeds = [1]\n')}
    folder.mkdir(parents=True, exist_ok=True)
    cases = []
    for surface, files in (("trajectory", trajectory), ("wind", wind), ("faults", faults)):
        for label, content in files.items():
            suffix = label.split()[0] if label.split()[0] in ("csv", "yaml", "json") else "json"
            path = folder / f"{surface}_{len(cases)}.{suffix}"
            path.write_bytes(content if isinstance(content, bytes) else content.encode())
            cases.append((f"{surface} file: {label}", [*run, f"--{surface}", str(path)]))
    (folder / "bomb.yaml").write_text(_yaml_bomb())
    (folder / "wind.json").write_text('{"steady": [1e300, 0, 0]}')
    for label, (suffix, content) in specs.items():
        path = folder / f"spec_{len(cases)}.{suffix}"
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
        cases.append((f"campaign spec: {label}", ["campaign", str(path), "--out", str(folder / "camp")]))
    if hasattr(os, "mkfifo"):
        for flag, name in (("--trajectory", "fifo.csv"), ("--wind", "fifo.yaml"), ("--faults", "fifo.json")):
            os.mkfifo(folder / name)
            cases.append((f"{flag} a FIFO", [*run, flag, str(folder / name)]))
        cases.append(("campaign spec a FIFO", ["campaign", str(folder / "fifo.yaml")]))
    for flag in ("--trajectory", "--wind", "--faults"):
        cases.append((f"{flag} /dev/zero", [*run, flag, "/dev/zero"]))
        cases.append((f"{flag} a folder", [*run, flag, str(folder)]))
    return cases

# ---- end of issue 37's input-layer block ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def misbehaving(tmp_path_factory):
    acts = {"segfault": "os.kill(os.getpid(), signal.SIGSEGV)", "abort": "os.abort()", "exit": "os._exit(3)",
            "hang": "time.sleep(3600)", "nan": "return float('nan'), 0.0, 0.0, 0.0", "raise": "raise RuntimeError('boom')",
            "wrong arity": "return 1.0, 2.0"}
    return wrap_misbehaving(tmp_path_factory.mktemp("fuzz_misbehaving"), acts, 0.1)


@pytest.mark.slow
def test_over_300_bad_inputs_each_get_one_line_and_a_non_zero_exit(fmus, misbehaving, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # relative outputs (runs/, designs/) land here
    cases = _cli_cases() + _set_cases() + _parameter_cases(fmus) + _files(tmp_path, fmus, misbehaving)
    cases += _scenario_file_cases(tmp_path / "scenario_files")
    assert len(cases) >= 300, len(cases)
    problems = []
    for label, argv in cases:
        if argv[:1] == ["run"] and "--fmus" not in argv:
            argv = [*argv, "--fmus", str(fmus), "--out", str(tmp_path / "runs")]
        code = exit_code(argv)
        out, err = capsys.readouterr()
        lines = [ln for ln in err.splitlines() if ln.strip()]
        if code in (0, None):
            problems.append(f"{label}: exit 0")
        elif len(lines) != 1:
            problems.append(f"{label}: {len(lines)} lines on stderr: {lines[:3]}")
        elif "Traceback" in err or EXCEPTION_NAME.search(lines[0]):
            problems.append(f"{label}: {lines[0]}")
        elif "error" not in lines[0]:
            problems.append(f"{label}: not an error line: {lines[0]}")
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


# ====================================================================================================================
# Issue 37, trust boundaries (branch trust-snapshot): snapshots, remote options and token files, FMI 3.0 options.
# Kept apart from the cases above (and from the input-file layer's) so that merges stay simple. Every case here is
# refused with one line and exit 2: a user's to fix.
# ====================================================================================================================

SNAPSHOT_KEYS = ("format", "tick", "ticks_done", "fingerprint", "values", "delay_lines", "faults", "manipulator", "observers",
                 "application", "states")
OPTION_KEYS = ("vehicle", "scenario", "trajectory", "controller", "controller_fmu", "seed", "stop_time", "delay", "gusts",
               "faults", "settings", "system", "fmus", "allow_unknown_inputs", "reference", "wind", "allow_infeasible",
               "max_tilt", "allow_external_fmus", "remotes", "fmi", "clocks")


def _snapshot_with(src: Path, dest: Path, manifest=None, members: dict | None = None, drop: tuple = ()) -> Path:
    """src's archive with its manifest replaced (a function of the parsed one, or raw bytes) and members added or
    dropped."""
    with zipfile.ZipFile(src) as z, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as out:
        for item in z.infolist():
            if item.filename in drop:
                continue
            data = z.read(item.filename)
            if item.filename == "manifest.json" and manifest is not None:
                data = manifest if isinstance(manifest, bytes) else json.dumps(manifest(json.loads(data))).encode()
            out.writestr(item.filename, data)
        for name, data in (members or {}).items():
            out.writestr(name, data)
    return dest


def _at(path: tuple, value):
    """A manifest edit: set (or with value KeyError, delete) the item at path."""
    def edit(m):
        target = m
        for key in path[:-1]:
            target = target[key]
        if value is KeyError:
            del target[path[-1]]
        else:
            target[path[-1]] = value
        return m
    return edit


def _snapshot_cases(folder: Path, good: Path) -> list[tuple[str, list[str]]]:
    cases = []
    edits = [(f"no {key}", (key,), KeyError) for key in SNAPSHOT_KEYS]
    edits += [(f"{key} a list", (key,), []) for key in SNAPSHOT_KEYS if key not in ("faults", "states")]
    edits += [("unknown key", ("extra",), 1), ("format 1", ("format",), "tiltload-snapshot/1"), ("format null", ("format",), None),
              ("ticks_done -1", ("ticks_done",), -1), ("ticks_done 1.5", ("ticks_done",), 1.5),
              ("ticks_done a string", ("ticks_done",), "1"), ("ticks_done 2^60", ("ticks_done",), 2**60),
              ("tick 0", ("tick",), 0), ("tick -0.012", ("tick",), -0.012), ("tick true", ("tick",), True),
              ("no instances", ("fingerprint", "instances"), []), ("instances an object", ("fingerprint", "instances"), {}),
              ("sha256 not hex", ("fingerprint", "instances", 0, "sha256"), "zz"),
              ("sha256 of another file", ("fingerprint", "instances", 3, "sha256"), "0" * 64),
              ("every 0", ("fingerprint", "instances", 0, "every"), 0),
              ("instance name a path", ("fingerprint", "instances", 0, "name"), "../x"),
              ("state name a path", ("states",), ["../../etc/passwd"]), ("state names not strings", ("states",), [1]),
              ("states repeated", ("states",), ["plant", "plant"]), ("values of a path", ("values", "../x"), {}),
              ("values of an unknown type", ("values", "plant", "Complex"), [1]),
              ("values not numbers", ("values", "plant", "Real"), ["x"]),
              ("values the wrong length", ("values", "plant", "Real"), [1.0]),
              ("observers a list", ("observers",), []), ("application options missing", ("application", "options"), KeyError),
              ("stop -1", ("application", "stop"), -1), ("stop a string", ("application", "stop"), "x"),
              ("schedule unknown", ("application", "schedule"), "chaos")]
    edits += [(f"option {key} missing", ("application", "options", key), KeyError) for key in OPTION_KEYS]
    edits += [(f"option {key} a list", ("application", "options", key), [[]]) for key in OPTION_KEYS if key not in ("settings", "remotes")]
    edits += [("option unknown", ("application", "options", "colour"), "red"),
              ("options of another scenario", ("application", "options", "scenario"), "lkf"),
              ("options of another seed", ("application", "options", "seed"), 7),
              ("options of another trajectory", ("application", "options", "trajectory"), 2),
              ("options without gusts", ("application", "options", "gusts"), False),
              ("options of the UAV alone", ("application", "options", "vehicle"), "uav"),
              ("options naming a controller FMU", ("application", "options", "controller_fmu"), str(good)),
              ("options naming a system", ("application", "options", "system"), str(good)),
              ("options at FMI 3.0", ("application", "options", "fmi"), 3)]
    for i, (label, path, value) in enumerate(edits):
        snap = _snapshot_with(good, folder / f"snap_{i}.snapshot", _at(path, value))
        cases.append((f"snapshot {label}", ["run", "--from-snapshot", str(snap)]))
    raw = {"manifest not JSON": b"{", "manifest a list": b"[]", "manifest nested 100000 deep": b"[" * 100_000,
           "manifest binary": bytes(range(256))}
    for i, (label, data) in enumerate(raw.items()):
        cases.append((f"snapshot {label}", ["run", "--from-snapshot", str(_snapshot_with(good, folder / f"raw_{i}.snapshot", data))]))
    cases.append(("snapshot without its manifest", ["run", "--from-snapshot",
                                                    str(_snapshot_with(good, folder / "nomanifest.snapshot", drop=("manifest.json",)))]))
    cases.append(("snapshot without a state", ["run", "--from-snapshot",
                                               str(_snapshot_with(good, folder / "nostate.snapshot", drop=("fmu/plant.state",)))]))
    fifo = folder / "snapshot.fifo"
    os.mkfifo(fifo)
    for label, path in {"a folder": folder, "a FIFO": fifo, "a device": Path("/dev/zero"), "missing": folder / "nope.snapshot",
                        "a text file": folder / "raw_yaml.json"}.items():
        cases.append((f"snapshot {label}", ["run", "--from-snapshot", str(path)]))
    for stop in ["0.1", "0.5"]:
        cases.append((f"continued run stopping at {stop} s", ["run", "--from-snapshot", str(good), "--stop-time", stop]))
    for flag in (["--scenario", "lkf"], ["--controller", "dlqr"], ["--controller", str(good)], ["--system", str(good)],
                 ["--fmi", "3"], ["--clocks"], ["--wind", str(good)], ["--snapshot-at", "0.7", str(folder / "x.snapshot")]):
        cases.append((f"continued run with {flag[0]}", ["run", "--from-snapshot", str(good), *flag]))
    cases.append(("campaign from a damaged snapshot", ["campaign", str(_branch_spec(folder, "snap_0.snapshot"))]))
    lkf = next(i for i, edit in enumerate(edits) if edit[0] == "options of another scenario")
    cases.append(("campaign from another scenario's", ["campaign", str(_branch_spec(folder, f"snap_{lkf}.snapshot"))]))
    return cases


def _branch_spec(folder: Path, snapshot: str) -> Path:
    path = folder / f"branch_{snapshot}.toml"
    path.write_text(f'name = "b"\n[base]\nsnapshot = "{snapshot}"\nstop_time = 1.0\n[vary]\nseeds = [1, 2]\n')
    return path


def _remote_cases(folder: Path, fmus: Path) -> list[tuple[str, list[str]]]:
    from support.remote import token_file

    good = token_file(folder, "good_token")
    kinds = {"missing": folder / "no_token", "a folder": folder, "a device": Path("/dev/zero"), "a FIFO": folder / "token.fifo",
             "world-readable": folder / "loose_token", "short": folder / "short_token", "large": folder / "large_token",
             "empty": folder / "empty_token"}
    os.mkfifo(kinds["a FIFO"], 0o600)
    kinds["world-readable"].write_text("x" * 40)
    kinds["world-readable"].chmod(0o644)
    kinds["short"].write_text("abc\n")
    kinds["large"].write_bytes(b"x" * 5000)
    kinds["empty"].write_bytes(b"")
    for path in (kinds["short"], kinds["large"], kinds["empty"]):
        path.chmod(0o600)
    remote = ["run", "--remote", "controller=127.0.0.1:9"]
    serve = ["serve", "--fmus", str(fmus)]
    cases = []
    for label, path in kinds.items():
        cases.append((f"run token file {label}", [*remote, "--token-file", str(path)]))
        cases.append((f"serve token file {label}", [*serve, "--token-file", str(path)]))
    cases.append(("run remote without a token file", remote))
    for value in ["controller", "controller=", "=127.0.0.1:9", "controller=host", "controller=host:0", "controller=host:99999",
                  "controller=:9", "controller=127.0.0.1:x", "controller=a b:9", ""]:
        cases.append((f"remote {value!r}", ["run", "--remote", value, "--token-file", str(good)]))
    for option in ["--handshake-timeout", "--idle-timeout"]:
        for value in [*BAD_NUMBERS, "1e12", "86401", "1e300"]:
            cases.append((f"serve {option}={value!r}", [*serve, "--token-file", str(good), option, value]))
    for value in ["0", "-1", "x", "1.5", "1e3", "99999", ""]:
        cases.append((f"serve clients-per-fmu={value!r}", [*serve, "--token-file", str(good), "--clients-per-fmu", value]))
    for value in ["x", "1.2.3.4:99999", ":", "host:-1", ""]:
        cases.append((f"serve bind={value!r}", [*serve, "--token-file", str(good), "--bind", value]))
    cases.append(("serve a missing folder", ["serve", "--fmus", str(folder / "nowhere"), "--token-file", str(good)]))
    for value in ["1e12", "86401", "1e300"]:
        cases.append((f"step-timeout={value!r}", ["run", "--step-timeout", value]))
    for value in ["0", "1e-12", "1e6", "nan", "x"]:
        cases.append((f"realtime={value!r}", ["run", "--realtime", value]))
    for value in ["0", "-1", "1e12", "x"]:
        cases.append((f"campaign connect-timeout={value!r}", ["campaign", "spec.toml", "--connect-timeout", value]))
        cases.append((f"campaign worker-timeout={value!r}", ["campaign", "spec.toml", "--worker-timeout", value]))
    for flag in (["--token", "SECRET-0123456789abcdef"], ["--token-f", str(good)], ["--stop", "1"], ["--from", "x"],
                 ["--snap", "1", "x"], ["--fmu", str(fmus)], ["--step", "1"]):
        cases.append((f"abbreviation {flag[0]}", ["run", *flag]))
    cases.append(("serve abbreviation --token", ["serve", "--fmus", str(fmus), "--token", str(good)]))
    return cases


def _fmi3_cases(folder: Path, fmi3: dict[str, Path]) -> list[tuple[str, list[str]]]:
    from support.remote import token_file

    token = token_file(folder, "fmi3_token")
    cases = []
    for value in ["4", "1", "3.0", "x", ""]:
        cases.append((f"fmi={value!r}", ["run", "--fmi", value]))
    cases.append(("clocks without fmi 3", ["run", "--clocks"]))
    cases.append(("clocks with fmi 2", ["run", "--fmi", "2", "--clocks"]))
    for clocks in ([], ["--clocks"]):  # FMI 3.0 FMUs are hosted remotely now: a bad address is still the user's to fix
        cases.append((f"fmi 3{' clocks' * bool(clocks)} remote, no port", ["run", "--fmi", "3", *clocks, "--remote",
                                                                             "controller=127.0.0.1", "--token-file", str(token)]))
    controller = fmi3["TiltloadController"]

    def edited(label, edit):
        path = folder / f"fmi3_{len(cases)}.fmu"
        with zipfile.ZipFile(controller) as src, zipfile.ZipFile(path, "w") as out:
            for item in src.infolist():
                data = src.read(item.filename)
                if item.filename == "modelDescription.xml":
                    data = edit(data.decode()).encode()
                out.writestr(item, data)
        cases.append((f"FMI 3.0 controller FMU: {label}", ["run", "--controller", str(path)]))

    edited("no instantiationToken", lambda x: re.sub(r'\s+instantiationToken="[^"]*"', "", x))
    edited("empty instantiationToken", lambda x: re.sub(r'instantiationToken="[^"]*"', 'instantiationToken=""', x))
    edited("model exchange only", lambda x: x.replace("<CoSimulation", "<ModelExchange").replace("</CoSimulation", "</ModelExchange"))
    edited("broken XML", lambda x: x[: len(x) // 2])
    return cases


@pytest.fixture(scope="module")
def taken_snapshot(fmus, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("bad_snapshots") / "good.snapshot"
    assert main(["run", "--stop-time", "1", "--snapshot-at", "0.5", str(path), "--fmus", str(fmus), "--no-log", "--quiet",
                 "--no-plots"]) == 0
    return path


@pytest.mark.slow
def test_trust_boundary_bad_inputs_each_get_one_line_and_exit_2(fmus, fmi3_fmus, taken_snapshot, tmp_path, capsys,
                                                                 monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "raw_yaml.json").write_bytes(b"tick: 0.012\n")
    shutil.copy(taken_snapshot, tmp_path / "good.snapshot")
    good = tmp_path / "good.snapshot"
    cases = _snapshot_cases(tmp_path, good) + _remote_cases(tmp_path, fmus) + _fmi3_cases(tmp_path, fmi3_fmus)
    assert len(cases) >= 230, len(cases)
    problems = []
    for label, argv in cases:
        if argv[:1] == ["run"]:
            argv = [*argv, "--fmus", str(fmus), "--out", str(tmp_path / "runs"), "--stop-time", "1", "--quiet", "--no-plots",
                    "--no-log"] if "--stop-time" not in argv else [*argv, "--fmus", str(fmus), "--quiet", "--no-log"]
        if argv[:1] == ["campaign"]:
            argv = [*argv, "--fmus", str(fmus), "--out", str(tmp_path / "camp"), "--workers", "1"]
        code = exit_code(argv)
        out, err = capsys.readouterr()
        lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("campaign ")]
        if code != 2:
            problems.append(f"{label}: exit {code}: {lines[-1:] or out.splitlines()[-1:]}")
        elif len(lines) != 1:
            problems.append(f"{label}: {len(lines)} lines on stderr: {lines[:3]}")
        elif "Traceback" in err or EXCEPTION_NAME.search(lines[0]) or "a bug" in lines[0]:
            problems.append(f"{label}: {lines[0]}")
        elif "error" not in lines[0] or "SECRET" in err:
            problems.append(f"{label}: not an error line, or a secret echoed: {lines[0]}")
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


# ====================================================================================================================
# Issue 49, every file opened as a file (user_files.open_binary / regular_file): each command that reads a file the
# user names, given a FIFO, a folder, a device, a missing path or one whose open is refused, answers one line naming
# what it is, exit 2, before anything blocks (a FIFO with no writer would block an ordinary open forever).
# ====================================================================================================================

def _not_a_file_kinds(folder: Path, suffix: str) -> dict[str, tuple[Path, str]]:
    """label -> (path, what the line must say)."""
    fifo, sub = folder / f"pipe{suffix}", folder / f"folder{suffix}"
    if not fifo.exists():
        os.mkfifo(fifo)
        sub.mkdir()
        (folder / f"locked{suffix}").write_bytes(b"\x89MCAP0\r\n" if suffix == ".mcap" else b"x: 1\n")
    return {"a FIFO": (fifo, "a FIFO, not a regular file"), "a folder": (sub, "a folder, not a regular file"),
            "a device": (Path("/dev/zero"), "a character device, not a regular file"),
            "missing": (folder / f"none{suffix}", "no such file"),
            "unreadable": (folder / f"locked{suffix}", "permission denied")}


def _file_commands(folder: Path) -> list[tuple[str, str, list[str]]]:
    """(label, the bad file's suffix, argv with {} where it goes)."""
    log = folder / "real.mcap"
    log.write_bytes(b"\x89MCAP0\r\n")  # only its magic: the bad file beside it is refused before this one is read
    reqs = folder / "reqs.yaml"
    reqs.write_text("requirements:\n  - name: a\n    formula: always[0:1] plant.z < 1\n")
    return [("check's requirement file", ".yaml", ["check", "{}", str(log)]),
            ("check's log", ".mcap", ["check", str(reqs), "{}"]),
            ("check --formula's log", ".mcap", ["check", "--formula", "a: always[0:1] plant.z < 1", "{}"]),
            ("plot's log", ".mcap", ["plot", "{}", "--out", str(folder / "plots")]),
            ("compare's log", ".mcap", ["compare", "{}", str(folder / "b.json")]),
            ("campaign's spec", ".toml", ["campaign", "{}", "--out", str(folder / "camp")]),
            ("falsify's spec", ".yaml", ["falsify", "{}", "--out", str(folder / "fals")]),
            ("campaign-report's results", ".parquet", ["campaign-report", "{}"]),
            ("a snapshot", ".snapshot", ["run", "--from-snapshot", "{}", "--no-log", "--quiet", "--no-plots"]),
            ("wrap's controller", ".py", ["wrap", "{}", "--out", str(folder / "w.fmu")])]


def test_every_file_a_command_reads_is_opened_as_a_file(tmp_path, capsys, monkeypatch):
    """Generated: 10 file arguments x 5 kinds of not-a-file = 50 cases, each one line naming what the path is."""
    import errno

    real_open = os.open

    def refusing_open(path, flags, *args, **kwargs):  # we run as root, who reads every file: refuse these opens instead
        if Path(path).name.startswith("locked"):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", refusing_open)
    monkeypatch.chdir(tmp_path)
    cases = []
    for label, suffix, argv in _file_commands(tmp_path):
        for kind, (path, says) in _not_a_file_kinds(tmp_path, suffix).items():
            cases.append((f"{label}: {kind}", [str(path) if a == "{}" else a for a in argv], says))
    assert len(cases) == 50
    problems = []
    for label, argv, says in cases:
        code = exit_code(argv)
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip() and not ln.startswith("tiltload run: ")]
        if code != 2 or len(lines) != 1 or says not in lines[0] or EXCEPTION_NAME.search(lines[0]):
            problems.append(f"{label}: exit {code}: {lines[:3]}")
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


# ====================================================================================================================
# Issue 49, logs from other tools (engine/log/reader.py): MCAPs written by the mcap package's own writer the way other
# tools write them, and chunks that declare or inflate to more than a chunk may hold. Each is one line naming the
# channel and what tiltload expected there (or the chunk, as damage), exit 2, never a traceback nor a decompression
# of gigabytes.
# ====================================================================================================================

def _foreign_log(path: Path, encoding: str, messages: list[bytes], schema: tuple[str, str, bytes] | None = None,
                 metadata: dict | None = None) -> Path:
    """An MCAP of one channel /plant, written by the mcap package (as another tool would write it)."""
    from mcap.writer import Writer

    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2" if encoding == "cdr" else "", library="another-tool 1.0")
        schema_id = writer.register_schema(*schema) if schema else 0
        channel = writer.register_channel("/plant", encoding, schema_id, metadata or {})
        for i, data in enumerate(messages):
            writer.add_message(channel, log_time=i * 12_000_000, data=data, publish_time=i * 12_000_000, sequence=i)
        writer.finish()
    return path


def _raw_chunk_log(path: Path, declared: int, payload: bytes) -> Path:
    """An MCAP whose one chunk declares `declared` uncompressed bytes and holds payload, zstd-compressed (written
    record by record: no writer makes such a chunk)."""
    import zlib

    import zstandard
    from mcap.data_stream import RecordBuilder
    from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message

    inner = RecordBuilder()
    Channel(id=1, topic="/plant", message_encoding="json", metadata={}, schema_id=0).write(inner)
    Message(channel_id=1, log_time=0, data=b'{"t": 0.0, "x": 1.0}', publish_time=0, sequence=0).write(inner)
    records = inner.end() + payload
    out = RecordBuilder()
    Header(profile="", library="another-tool").write(out)
    Chunk(compression="zstd", data=zstandard.ZstdCompressor(level=1).compress(records), message_start_time=0,
          message_end_time=0, uncompressed_crc=zlib.crc32(records), uncompressed_size=declared).write(out)
    DataEnd(data_section_crc=0).write(out)
    Footer(summary_start=0, summary_offset_start=0, summary_crc=0).write(out)
    magic = b"\x89MCAP0\r\n"
    path.write_bytes(magic + out.end() + magic)
    return path


def _foreign_logs(folder: Path) -> dict[str, tuple[Path, str]]:
    """label -> (log, a word the line must hold)."""
    from google.protobuf import descriptor_pb2 as d

    fds = d.FileDescriptorSet()
    proto = fds.file.add(name="pose.proto", package="geometry")
    message = proto.message_type.add(name="Pose")
    message.field.add(name="position", number=1, type=d.FieldDescriptorProto.TYPE_STRING)
    foreign_schema = fds.SerializeToString()
    number = b'{"t": 0.0, "x": 1.0}'
    logs = {
        "ROS 2 CDR": (_foreign_log(folder / "ros2.mcap", "cdr", [b"\x00\x01\x00\x00" + bytes(24)] * 3,
                                   ("geometry_msgs/msg/Pose", "ros2msg", b"float64 x")), "cdr"),
        "ROS 1": (_foreign_log(folder / "ros1.mcap", "ros1", [bytes(24)] * 3, ("geometry_msgs/Pose", "ros1msg", b"float64 x")),
                  "ros1"),
        "CBOR": (_foreign_log(folder / "cbor.mcap", "cbor", [b"\xa1\x61x\x01"] * 3), "cbor"),
        "flatbuffer": (_foreign_log(folder / "fb.mcap", "flatbuffer", [bytes(16)] * 3, ("Pose", "flatbuffer", b"\x00" * 8)),
                       "flatbuffer"),
        "a foreign protobuf schema": (_foreign_log(folder / "proto.mcap", "protobuf", [b"\x0a\x03abc"] * 3,
                                                   ("geometry.Pose", "protobuf", foreign_schema)), "geometry.Pose"),
        "a protobuf schema that claims tiltload's layout": (
            _foreign_log(folder / "claims.mcap", "protobuf", [b"\x0a\x03abc"] * 3, ("geometry.Pose", "protobuf", foreign_schema),
                         {"layout": __import__("tiltload.master.engine.log.encoding", fromlist=["LAYOUT"]).LAYOUT}),
            "fixed layout"),
        "a protobuf schema that is garbage": (
            _foreign_log(folder / "garbage.mcap", "protobuf", [b"\x00"] * 3, ("x", "protobuf", b"\xff\xff\xff"),
                         {"layout": __import__("tiltload.master.engine.log.encoding", fromlist=["LAYOUT"]).LAYOUT}),
            "fixed layout"),
        "JSON text where a number goes": (_foreign_log(folder / "text.mcap", "json", [number, b'{"t": 0.012, "x": "high"}']),
                                          "where a number goes"),
        "JSON text where its schema says number": (
            _foreign_log(folder / "typed.mcap", "json", [b'{"t": 0.0, "x": "high"}'],
                         ("pose", "jsonschema", b'{"type": "object", "properties": {"x": {"type": "number"}}}')),
            "where a number goes"),
        "JSON text as the time": (_foreign_log(folder / "time.mcap", "json", [b'{"t": "noon", "x": 1.0}']), "where a number"),
        "JSON arrays": (_foreign_log(folder / "array.mcap", "json", [b"[1, 2]"] * 2), "an object"),
        "JSON not JSON": (_foreign_log(folder / "notjson.mcap", "json", [b"\xff\xfe x"] * 2), "not JSON"),
        "JSON nested 100000 deep": (_foreign_log(folder / "deep.mcap", "json", [b"[" * 100_000]), "not JSON"),
        "a chunk declaring a terabyte": (_raw_chunk_log(folder / "tera.mcap", 2**40, b""), "refused unread"),
        "a chunk inflating beyond its size": (_raw_chunk_log(folder / "bomb.mcap", 60, bytes(64 * 2**20)), "inflates to more"),
    }
    return logs


def test_logs_from_other_tools_are_one_line_naming_the_channel(tmp_path, capsys):
    """Generated: 15 foreign logs x 3 commands (check, plot, compare) = 45 cases."""
    (tmp_path / "b.json").write_text('{"metrics": {"ISE_x": 1.0}}')
    cases = []
    for label, (log, says) in _foreign_logs(tmp_path).items():
        cases += [(f"check, {label}", ["check", "--formula", "a: plant.x < 5", str(log)], says),
                  (f"plot, {label}", ["plot", str(log), "--out", str(tmp_path / "plots")], says),
                  (f"compare, {label}", ["compare", str(log), str(tmp_path / "b.json")], says)]
    assert len(cases) == 45
    problems = []
    for label, argv, says in cases:
        code = exit_code(argv)
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        if code != 2 or len(lines) != 1 or says not in lines[0] or EXCEPTION_NAME.search(lines[0]) or "a bug" in lines[0]:
            problems.append(f"{label}: exit {code}: {lines[:3]}")
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


# ====================================================================================================================
# Issue 49, output folders and resumed state (app/output_folder.py, app/batch/parts.py): campaign, falsify and
# campaign-report refuse an output folder they could not write, and stored parts that are not parts, in one line
# before any FMU is built or any cluster started (local_cluster is replaced by a tripwire here).
# ====================================================================================================================

CAMPAIGN_SPEC = """name = "small"
[base]
scenario = "fsi"
controllers = ["dlqr"]
stop_time = 0.5
[vary]
seeds = [1, 2]
"""

FALSIFY_SPEC = """name = "t"
optimizer = "uniform"
[base]
scenario = "fsi"
stop_time = 2.5
gusts = false
[[requirements]]
name = "swing"
formula = "always[0:2] (abs(plant.gamma_1) < 0.2)"
[[search]]
name = "amp"
target = "gust.amplitude"
range = [0.0, 20.0]
[gust]
start = 0.5
duration = 0.5
[budget]
simulations = 2
"""


@pytest.fixture
def small_mounts(tmp_path):
    """(a read-only folder, a full folder) as tmpfs mounts of 64 KiB, each holding a results.parquet; None where this
    machine does not let us mount (then those cases are left out)."""
    import subprocess

    made, mounted = [], []
    try:
        yield _mount_both(tmp_path, made, mounted)
    finally:
        for where in mounted:
            subprocess.run(["umount", str(where)], capture_output=True)


def _mount_both(tmp_path: Path, made: list, mounted: list) -> tuple:
    import subprocess

    import pyarrow as pa
    import pyarrow.parquet as pq

    for name in ("readonly", "full"):
        where = tmp_path / name
        where.mkdir()
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(where)], capture_output=True).returncode:
            made.append(None)
            continue
        mounted.append(where)
        pq.write_table(pa.Table.from_pylist([{"run_id": "r0", "controller": "dlqr", "seed": 1, "completed": True}]),
                       where / "results.parquet")
        if name == "full":
            fd = os.open(where / "filler", os.O_WRONLY | os.O_CREAT)
            try:
                while os.write(fd, b"\0" * 4096):
                    pass
            except OSError:  # ENOSPC: the disk is full
                pass
            finally:
                os.close(fd)
        else:
            subprocess.run(["mount", "-o", "remount,ro", str(where)], check=True)
        made.append(where)
    return tuple(made)


def _bad_parts() -> dict[str, bytes | list[dict]]:
    """label -> a part's bytes, or its rows (written as Parquet)."""
    return {"garbage": b"PAR1 not parquet at all", "empty": b"", "a Parquet of no rows": [],
            "another tool's Parquet": [{"a": 1, "b": "x"}], "a run id that is a number": [{"run_id": 7, "index": 0,
                                                                                           "completed": True}],
            "an index that is text": [{"run_id": "r", "index": "first", "completed": True}]}


def test_output_folders_and_stored_parts_are_refused_before_a_cluster(tmp_path, capsys, monkeypatch, small_mounts):
    import pyarrow as pa
    import pyarrow.parquet as pq
    from tiltload.master.app import output_folder
    from tiltload.master.app.batch import cluster

    def tripwire(*args, **kwargs):
        raise AssertionError("a cluster was started")

    monkeypatch.setattr(cluster, "local_cluster", tripwire)
    monkeypatch.chdir(tmp_path)
    camp, fals = tmp_path / "c.toml", tmp_path / "f.toml"
    camp.write_text(CAMPAIGN_SPEC)
    fals.write_text(FALSIFY_SPEC)
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    readonly, full = small_mounts
    outs = {"a file": (a_file, "is a file, not a folder"), "under a file": (a_file / "out", "is a file, so no folder"),
            "a disk that says 1 KiB free": (tmp_path / "tiny", "KiB free")}
    if readonly is not None:
        outs |= {"read-only": (readonly / "out", "read-only"), "full": (full / "out", "disk is full")}
    cases = []
    for label, (out, says) in outs.items():
        cases.append((f"campaign --out {label}", ["campaign", str(camp), "--out", str(out), "--workers", "1"], says))
        cases.append((f"falsify --out {label}", ["falsify", str(fals), "--out", str(out), "--workers", "1"], says))
    if readonly is not None:
        cases += [("campaign-report in a read-only folder", ["campaign-report", str(readonly / "results.parquet")], "read-only"),
                  ("campaign-report on a full disk", ["campaign-report", str(full / "results.parquet")], "disk is full")]
    for i, (label, part) in enumerate(_bad_parts().items()):
        for command, spec in (("campaign", camp), ("falsify", fals)):
            if command == "campaign" and "index" in label:  # a campaign's parts have no index: that part is one
                continue
            out = tmp_path / f"{command}_{i}"
            (out / "parts").mkdir(parents=True)
            name = out / "parts" / ("000000.parquet" if command == "falsify" else "r0+1-abc.parquet")
            if isinstance(part, bytes):
                name.write_bytes(part)
            else:
                pq.write_table(pa.Table.from_pylist(part) if part else pa.table({"run_id": pa.array([], pa.string())}), name)
            cases.append((f"{command}, a stored part: {label}", [command, str(spec), "--out", str(out), "--workers", "1"],
                          f"stored part {name}"))
    assert len(cases) >= 18, len(cases)
    problems = []
    real_usage = output_folder.shutil.disk_usage
    for label, argv, says in cases:
        tiny = "1 KiB" in label
        monkeypatch.setattr(output_folder.shutil, "disk_usage",
                            (lambda p: real_usage(p)._replace(free=1024)) if tiny else real_usage)
        code = exit_code(argv)
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        if code != 2 or len(lines) != 1 or says not in lines[0] or EXCEPTION_NAME.search(lines[0]) or "a bug" in lines[0]:
            problems.append(f"{label}: exit {code}: {lines[:3]}")
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


def _interrupt_when(proc, ready, deadline_s: float = 300.0) -> None:
    """SIGINT to the process group (what Ctrl-C at a terminal does) once ready() holds (polled), or at the deadline."""
    import signal
    import time

    end = time.monotonic() + deadline_s
    while proc.poll() is None and not ready() and time.monotonic() < end:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)


@pytest.mark.slow
@pytest.mark.parametrize("when", ["while the workers start", "while the runs run"])
def test_ctrl_c_in_a_campaign_is_one_line_with_nothing_left(fmus, tmp_path, when):
    """Ctrl-C reaches every process of the group; only `tiltload: interrupted` (after the campaign's own first line)
    reaches the terminal: no worker's traceback, no Dask log line; no process and no scratch folder stays behind."""
    import signal
    import subprocess
    import sys

    import psutil

    spec = tmp_path / "c.toml"
    spec.write_text(CAMPAIGN_SPEC.replace("stop_time = 0.5", "stop_time = 40").replace("seeds = [1, 2]", "seeds = [1, 2, 3, 4, 5, 6]"))
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    err = tmp_path / "stderr"
    with open(err, "wb") as stderr:
        proc = subprocess.Popen([sys.executable, "-m", "tiltload.master.app.cli", "campaign", str(spec), "--out", str(tmp_path / "out"),
                                 "--workers", "2", "--fmus", str(fmus)], stdout=subprocess.DEVNULL, stderr=stderr,
                                start_new_session=True, env={**os.environ, "TMPDIR": str(scratch)},
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))

        def spawned() -> bool:  # a worker process exists (it may still be importing)
            try:
                return any("multiprocessing" in " ".join(c.cmdline()) for c in psutil.Process(proc.pid).children(recursive=True))
            except psutil.Error:
                return False

        def running() -> bool:  # a run is stored
            return any((tmp_path / "out" / "parts").glob("*.parquet"))

        _interrupt_when(proc, spawned if when == "while the workers start" else running)
        code = proc.wait(timeout=120)
    lines = [ln for ln in err.read_text().splitlines() if ln.strip()]
    alive = _group_left(proc.pid)
    assert code in (130, 0), lines  # 0: the campaign had finished before the signal came
    assert not [ln for ln in lines if "Traceback" in ln or "KeyboardInterrupt" in ln or "distributed." in ln], lines
    assert code == 0 or lines[-1] == "tiltload: interrupted", lines
    assert not alive, alive
    assert not list(scratch.iterdir()), list(scratch.iterdir())


def _group_left(pgid: int, grace_s: float = 10.0) -> list:
    """The group's live processes once they have had grace_s to finish exiting (the resource tracker ends when its
    pipe closes, a moment after the command)."""
    import time

    import psutil

    end = time.monotonic() + grace_s
    while True:
        alive = [p for p in psutil.process_iter(["pid"]) if _in_group(p, pgid)]
        if not alive or time.monotonic() > end:
            return alive
        time.sleep(0.2)


def _in_group(p, pgid: int) -> bool:
    """p is a live process of the group (a zombie has ended: whoever inherits it reaps it)."""
    import psutil

    try:
        return os.getpgid(p.pid) == pgid and p.status() != psutil.STATUS_ZOMBIE
    except (OSError, psutil.Error):
        return False


def fmus_commands(folder: Path) -> dict[str, list[str]]:
    """Every command with a --fmus that builds into it (a folder, or a path where one can be made); folder holds c.toml
    and f.toml."""
    return {"run": ["run", "--stop-time", "0.1"], "bundle": ["bundle", str(folder / "b.zip")],
            "campaign": ["campaign", str(folder / "c.toml")], "falsify": ["falsify", str(folder / "f.toml")],
            "formation": ["formation"], "reproduce": ["reproduce"], "ssp": ["ssp", "export", str(folder / "x.ssp")]}


def not_a_folder_paths(folder: Path) -> dict[str, tuple[str, str]]:
    """label -> (a path that cannot be a folder, what the line must say); folder holds the file fmus.zip."""
    a_file = folder / "fmus.zip"
    return {"a file": (str(a_file), "is a file, not a folder"), "under a file": (str(a_file / "fmus"), "is a file, so no folder"),
            "empty": ("", "an empty path")}


def test_every_fmus_option_that_is_not_a_folder_is_one_line(tmp_path, capsys, monkeypatch):
    """Generated: 7 commands x 3 paths that cannot be a folder (a file, under a file, empty) = 21 cases, each refused
    by the option's type (path_types.folder) before the command prepares anything."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "fmus.zip").write_bytes(b"PK")
    (tmp_path / "c.toml").write_text(CAMPAIGN_SPEC)
    (tmp_path / "f.toml").write_text(FALSIFY_SPEC)
    cases = [(f"{c} --fmus {label}", [*argv, f"--fmus={path}"], says) for c, argv in fmus_commands(tmp_path).items()
             for label, (path, says) in not_a_folder_paths(tmp_path).items()]
    assert len(cases) == 21
    problems = []
    for label, argv, says in cases:
        code = exit_code(argv)
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        if code != 2 or len(lines) != 1 or says not in lines[0] or "--fmus" not in lines[0]:
            problems.append(f"{label}: exit {code}: {lines[:3]}")
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


# ====================================================================================================================
# Issue 49, every path option by its kind (master/command_line/path_types.py): a folder to write into, a file to write, a folder to
# read (serve's --fmus); and the surfaces milestone 4 added last (b2b and compare's tubes, wrap --native, the API's
# Case and RunOptions, campaign-report on garbage), probed as a hostile user would.
# ====================================================================================================================

def path_option_cases(folder: Path) -> list[tuple[str, list[str], str]]:
    """(label, argv, what the line must say): every option naming a folder to write, a file to write, or serve's
    folder to read, given a path that cannot be that."""
    a_file, fifo = folder / "a_file", folder / "a_fifo"
    if not a_file.exists():
        a_file.write_text("x")
        os.mkfifo(fifo)
    log = folder / "l.mcap"
    out_folders = {"run --out": ["run", "--stop-time", "0.1", "--out"], "design --out": ["design", "--out"],
                   "formation --out": ["formation", "--out"], "reproduce --out": ["reproduce", "--out"],
                   "reproduce --baselines": ["reproduce", "--baselines"], "plot --out": ["plot", str(log), "--out"],
                   "compare --figures": ["compare", str(log), str(log), "--figures"], "b2b --out": ["b2b", "--out"],
                   "b2b --candidate-fmus": ["b2b", "--candidate-fmus"], "build --out": ["build", "--out"],
                   "campaign --out": ["campaign", "c.toml", "--out"], "falsify --out": ["falsify", "f.toml", "--out"]}
    out_files = {"run --report": ["run", "--stop-time", "0.1", "--report"], "check --report": ["check", str(log), "--report"],
                 "reproduce --docs": ["reproduce", "--docs"], "bundle OUT": ["bundle"], "ssp export OUT": ["ssp", "export"],
                 "layout OUT": ["layout"], "wrap --out": ["wrap", "c.py", "--out"]}
    cases = []
    for option, argv in out_folders.items():
        for label, path, says in (("a file", a_file, "is a file, not a folder"), ("a FIFO", fifo, "is a FIFO, not a folder"),
                                  ("under a file", a_file / "x", "is a file, so no folder")):
            cases.append((f"{option} {label}", [*argv, str(path)], says))
    for option, argv in out_files.items():
        for label, path, says in (("a folder", folder, "is a folder, not a file"), ("a FIFO", fifo, "is a FIFO, not a file"),
                                  ("under a file", a_file / "x.html", "is a file, so no file can be made")):
            cases.append((f"{option} {label}", [*argv, str(path)], says))
    serve = ["serve", "--token-file", str(a_file), "--fmus"]
    for label, path, says in (("a file", a_file, "is a file, not a folder"), ("under a file", a_file / "x", "a_file is a file"),
                              ("missing", folder / "nowhere", "no such folder"), ("a FIFO", fifo, "is a FIFO, not a folder"),
                              ("empty", "", "an empty path")):
        cases.append((f"serve --fmus {label}", [*serve, str(path)], says))
    return cases


def test_every_path_option_is_refused_by_its_kind_in_one_line(tmp_path, capsys, monkeypatch):
    """Generated: 12 folder options x 3 + 7 file options x 3 + serve's --fmus x 5 = 62 cases; each one line naming
    what the path is, exit 2 (a --report that was a folder, or --out a file, was "a bug" or an error after the run)."""
    monkeypatch.chdir(tmp_path)
    cases = path_option_cases(tmp_path)
    assert len(cases) == 62
    problems = []
    for label, argv, says in cases:
        code = exit_code(argv)
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        if code != 2 or len(lines) != 1 or says not in lines[0] or EXCEPTION_NAME.search(lines[0]):
            problems.append(f"{label}: exit {code}: {lines[:3]}")
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


def _controllers(folder: Path) -> dict[str, str]:
    """label -> the source of a controller class `wrap --native` must refuse in one line."""
    ports = "    inputs = ['x_ref', 'x']\n"
    step = "    def step(self, t, i):\n        return 0.0, 0.0, 0.0, 0.0\n"
    return {"no class": "def step(t, i):\n    return 0, 0, 0, 0\n", "a syntax error": "class C(:\n",
            "a decision on a traced value": "class C:\n" + ports + "    def step(self, t, i):\n        if i['x'] > 0:\n"
                                            "            return 1.0, 0.0, 0.0, 0.0\n        return 0.0, 0.0, 0.0, 0.0\n",
            "a number of a traced value": "class C:\n" + ports + "    def step(self, t, i):\n        return float(i['x']), 0, 0, 0\n",
            "a huge array": "import numpy as np\nclass C:\n" + ports + "    def __init__(self):\n        self.k = np.ones((300, 300))\n"
                            "    def step(self, t, i):\n        return self.k[0, 0] * i['x'], 0.0, 0.0, 0.0\n",
            "__init__ raises": "class C:\n" + ports + "    def __init__(self):\n        raise ValueError('boom')\n" + step,
            "__init__ loops without end": "class C:\n" + ports + "    def __init__(self):\n        while True:\n            pass\n" + step,
            "step loops without end": "class C:\n" + ports + "    def step(self, t, i):\n        while True:\n            pass\n",
            "step raises": "class C:\n" + ports + "    def step(self, t, i):\n        raise RuntimeError('x')\n",
            "step returns text": "class C:\n" + ports + "    def step(self, t, i):\n        return 'a'\n",
            "a port that is not one": "class C:\n    inputs = ['nothing']\n" + step,
            "a NaN gain": "class C:\n" + ports + "    def __init__(self):\n        self.k = float('nan')\n"
                          "    def step(self, t, i):\n        return self.k * i['x'], 0.0, 0.0, 0.0\n"}


def surface_cases(folder: Path, fmus: Path) -> list[tuple[str, str, list[str] | None, str | None, str]]:
    """(class, label, argv or None, API code or None, the exit expected): the surfaces milestone 4 added last."""
    from support.synthetic_log import write_log

    folder.mkdir(parents=True, exist_ok=True)
    t = np.arange(201) * 0.01
    log = write_log(folder / "a.mcap", {"plant": (t, {"x": np.sin(t), "z": -2 + 0 * t})}, stop_time=2.0)
    (folder / "a_file").write_text("x")
    cases = []
    tubes = "b2b and compare: tubes"
    sig = ["--signals", "plant.x,plant.z"]
    for flag in ("abs", "rel", "lead", "lag"):
        for value in ("-1", "nan", "inf", "-inf", "x", "1e400"):
            cases.append((tubes, f"compare --{flag} {value}", ["compare", str(log), str(log), *sig, f"--{flag}", value], None, "2"))
            cases.append((tubes, f"b2b --{flag} {value}", ["b2b", f"--{flag}", value], None, "2"))
    tolerance_files = {"no such signal": '[signals."plant.nothing"]\nabs = 1\n', "nan": "[default]\nrel = nan\n",
                       "text": '[default]\nabs = "1"\n', "not instance.variable": "[signals.x]\nabs = 1\n"}
    for i, (label, text) in enumerate(tolerance_files.items()):
        path = folder / f"tol{i}.toml"
        path.write_text(text)
        cases.append((tubes, f"compare tolerances: {label}", ["compare", str(log), str(log), "--tolerances", str(path)], None, "2"))
    cases.append((tubes, "compare --signals naming none", ["compare", str(log), str(log), "--signals", "plant.nothing"], None, "2"))
    case_lists = {"stop time -1": "stop_time = -1", "stop time nan": "stop_time = nan", "stop time 1e300": "stop_time = 1e300",
                  "seed of 20 digits": "seed = 99999999999999999999", "scenario a number": None, "no cases": None}
    for i, (label, field) in enumerate(case_lists.items()):
        path = folder / f"cases{i}.toml"
        one = 'scenario = "fsi", trajectory = 1, controller = "dlqr"'
        path.write_text("cases = []\n" if field is None and label == "no cases" else
                        "cases = [{scenario = 1, trajectory = 1}]\n" if field is None else f"cases = [{{{one}, {field}}}]\n")
        cases.append((tubes, f"b2b case list: {label}", ["b2b", "--cases", str(path), "--reference-fmus", str(fmus),
                                                         "--candidate-fmus", str(fmus)], None, "2"))
    for label, value in (("a text file", str(folder / "a_file")), ("no such name", "nothing"), ("a folder", str(folder))):
        cases.append((tubes, f"b2b --candidate-controller {label}", ["b2b", "--candidate-controller", value], None, "2"))
    for value in ("1e300", "nan", "-1", "0"):
        cases.append((tubes, f"b2b --stop-time {value}", ["b2b", "--stop-time", value], None, "2"))
    for label, where in (("a file", folder / "a_file"), ("a folder", folder), ("a device", Path("/dev/zero"))):
        cases.append((tubes, f"b2b --cases {label}", ["b2b", "--cases", str(where)], None, "2"))

    for i, (label, source) in enumerate(_controllers(folder).items()):
        path = folder / f"controller{i}.py"
        path.write_text(source)
        cases.append(("wrap --native", label, ["wrap", "--native", str(path), "--out", str(folder / f"w{i}.fmu")], None, "2"))

    api = "the API: Case and RunOptions"
    for field, values in {"stop_time": ["float('nan')", "float('inf')", "-1", "0", "1e300", "True", "'10'"],
                          "seed": ["2**70", "-1", "1.5", "'1'", "True"], "scenario": ["3", "'ekf'"], "trajectory": ["9", "'x'"],
                          "controller": ["3", "'pid'"], "set": ["'plant.m_L=1'", "{'plant.m_L': [1]}", "{'plant.m_L': 'abc'}",
                                                                 "{'plant.m_L': float('nan')}"],
                          "fmus": [repr(str(folder / "a_file")), "3"], "bogus": ["1"]}.items():
        for value in values:
            where = "" if field == "fmus" else f", fmus={str(fmus)!r}"
            run = f"tl.run(tl.Case({field}={value}{where}), tl.RunOptions(no_log=True, quiet=True))"
            cases.append((api, f"Case({field}={value})", None, run, "2"))
    for field, values in {"out": [repr(str(folder / "a_file")), "3"],
                          "report": [repr(str(folder)), repr(str(folder / "a_file" / "r.html"))],
                          "step_timeout": ["float('nan')", "-1", "1e12"], "realtime": ["float('inf')", "0"], "log_every": ["0", "1.5"],
                          "name": ["'../x'", "''"], "snapshot_at": ["(1e300, 'x.snapshot')", "'x'"], "bogus": ["1"]}.items():
        for value in values:
            run = f"tl.run(tl.Case(stop_time=0.1, fmus={str(fmus)!r}), tl.RunOptions({field}={value}))"
            cases.append((api, f"RunOptions({field}={value})", None, run, "2"))

    report = "campaign-report on garbage"
    garbage = {"text": b"x", "empty": b"", "a log": (folder / "a.mcap").read_bytes(), "parquet magic only": b"PAR1PAR1",
               "binary": bytes(range(256))}
    for i, (label, data) in enumerate(garbage.items()):
        path = folder / f"garbage{i}.parquet"
        path.write_bytes(data)
        cases.append((report, label, ["campaign-report", str(path)], None, "2"))
    cases.append((report, "a folder", ["campaign-report", str(folder)], None, "2"))
    cases.append((report, "--spec a folder", ["campaign-report", str(folder / "garbage0.parquet"), "--spec", str(folder)], None, "2"))
    return cases


def test_the_surfaces_added_last_refuse_bad_input_in_one_line(fmus, tmp_path, capsys, monkeypatch):
    """Generated: b2b and compare's tubes, wrap --native, the API's Case and RunOptions, campaign-report on garbage;
    each one line, exit 2 (a TypeError or TiltloadError from the API), nothing left behind. A traced loop without end
    is cut at the tracer's time limit (here 2 s)."""
    from support.isolated_case import case_problems
    from tiltload.master.app.wrap import trace

    monkeypatch.setattr(trace, "TIME_LIMIT_S", 2.0)
    monkeypatch.chdir(tmp_path)
    cases = surface_cases(tmp_path / "surfaces", fmus)
    assert len(cases) >= 120, len(cases)
    problems = case_problems(cases, capsys, exception_names=True)  # the API's TypeError says its name, as Python's do
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


# ====================================================================================================================
# Issue 49, campaign-report (campaign/report.py): every keep option, results of other writers, the spec beside them,
# the rerun commands of a user's controller FMU.
# ====================================================================================================================

REPORT_SPEC = """name = "rep"
[base]
scenario = "fsi"
controllers = ["dlqr", "ctrl/mine.fmu"]
stop_time = 0.5
[vary]
seeds = [1, 2]
[[vary.parameters]]
name = "load_mass"
targets = ["plant.m_L"]
values = [0.05, 0.1]
"""
KEPT = {"ISE": ("ISE(",), "IADU": ("IADU(",), "max_tracking_error": ("max_tracking_error",),
        "time_saturated": ("time_saturated",), "zse_containment": ("zse_containment",)}


@pytest.fixture(scope="module")
def user_campaign(fmus, tmp_path_factory) -> Path:
    """The results of a small campaign over dlqr and a user's controller FMU (a copy of ours, under another name),
    every metric kept."""
    folder = tmp_path_factory.mktemp("user_campaign")
    (folder / "ctrl").mkdir()
    shutil.copy(fmus / "TiltloadController.fmu", folder / "ctrl" / "mine.fmu")
    (folder / "spec.toml").write_text(REPORT_SPEC)
    assert main(["campaign", str(folder / "spec.toml"), "--out", str(folder / "out"), "--workers", "1", "--fmus", str(fmus)]) == 0
    return folder / "out" / "results.parquet"


def _results_with(results: Path, dest: Path, edit) -> Path:
    """A copy of the campaign's folder whose results.parquet holds edit(rows)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    shutil.copytree(results.parent, dest)
    rows = edit(pq.read_table(results).to_pylist())
    pq.write_table(pa.Table.from_pylist(rows), dest / "results.parquet")
    return dest / "results.parquet"


@pytest.mark.slow
def test_campaign_report_reads_every_writer_or_says_why(user_campaign, tmp_path, capsys):
    """Generated: each keep.metrics (alone, and all but it) and each older writer's missing column is reported (exit 0);
    text in each numeric column, a missing controller or run id, a spec beside the results that is not a spec: one
    line, exit 2."""
    import pyarrow.parquet as pq

    columns = pq.read_table(user_campaign).column_names
    metric_columns = [c for c in columns if c.startswith(("ISE(", "IADU(")) or c in ("max_tracking_error", "time_saturated",
                                                                                    "zse_containment")]
    good, bad = [], []
    for keep, prefixes in KEPT.items():  # what keep.metrics = [keep] writes: the other metrics' columns absent
        alone = [c for c in metric_columns if not c.startswith(prefixes)]
        good.append((f"keep.metrics = [{keep}]", lambda rows, drop=alone: [{k: v for k, v in r.items() if k not in drop}
                                                                            for r in rows]))
        good.append((f"keep.metrics without {keep}", lambda rows, p=prefixes: [{k: v for k, v in r.items()
                                                                                if not k.startswith(p)} for r in rows]))
    for column in ("seed", "diverged", "diverged_at", "error"):  # an older writer's rows without it
        good.append((f"no column {column}", lambda rows, c=column: [{k: v for k, v in r.items() if k != c} for r in rows]))
    good.append(("metrics renamed (ISE_x)", lambda rows: [{k.replace("(", "_").rstrip(")"): v for k, v in r.items()}
                                                          for r in rows]))
    for column in [*metric_columns, "load_mass"]:
        bad.append((f"text in {column}", lambda rows, c=column: [{**r, c: "high"} for r in rows], "where a number goes"))
    for value in (None, ""):
        bad.append((f"controller {value!r}", lambda rows, v=value: [{**r, "controller": v} for r in rows], "no controller"))
    bad.append(("run id None", lambda rows: [{**r, "run_id": None} for r in rows], "no run id"))
    bad.append(("completed text", lambda rows: [{**r, "completed": "yes"} for r in rows], "not true or false"))
    bad.append(("no column completed", lambda rows: [{k: v for k, v in r.items() if k != "completed"} for r in rows],
                "no column completed"))
    problems = []
    for i, (label, edit) in enumerate(good):
        results = _results_with(user_campaign, tmp_path / f"good_{i}", edit)
        code = exit_code(["campaign-report", str(results)])
        err = capsys.readouterr().err
        if code != 0 or not (results.parent / "report.md").is_file():
            problems.append(f"{label}: exit {code}: {err.strip()[:300]}")
    cases = [(label, _results_with(user_campaign, tmp_path / f"bad_{i}", edit), says) for i, (label, edit, says) in enumerate(bad)]
    for i, (label, text, says) in enumerate([("a spec that is not TOML", "name = ", "not valid TOML"),
                                             ("a spec of another tool", "[tool.poetry]\nname = 'x'\n", "spec.toml: (top level)"),
                                             ("a spec of a wrong type", REPORT_SPEC.replace("stop_time = 0.5", "stop_time = 'long'"),
                                              "base.stop_time")]):
        results = _results_with(user_campaign, tmp_path / f"spec_{i}", lambda rows: rows)
        (results.parent / "spec.toml").write_text(text)
        cases.append((label, results, says))
    for label, results, says in cases:
        code = exit_code(["campaign-report", str(results)])
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
        if code != 2 or len(lines) != 1 or says not in lines[0] or EXCEPTION_NAME.search(lines[0]) or "a bug" in lines[0]:
            problems.append(f"{label}: exit {code}: {lines[:3]}")
    assert len(good) + len(cases) >= 30, len(good) + len(cases)
    assert not problems, f"{len(problems)} of {len(good) + len(cases)} cases:\n" + "\n".join(problems)


@pytest.mark.slow
def test_the_reports_rerun_commands_name_a_users_controller_fmu_by_its_path(user_campaign, fmus, tmp_path, capsys):
    """The report's commands rerun a run of the user's FMU: its path (from the spec the campaign ran), and the command
    runs as printed (from another folder)."""
    import shlex

    assert main(["campaign-report", str(user_campaign)]) == 0
    capsys.readouterr()
    report = (user_campaign.parent / "report.md").read_text()
    commands = [ln.strip().strip("`") for ln in report.splitlines() if ln.strip().startswith("`tiltload run")]
    mine = [c for c in commands if "mine" in c]
    fmu = (user_campaign.parent.parent / "ctrl" / "mine.fmu").resolve()
    assert mine and all(f"--controller {fmu}" in c for c in mine), commands
    digest = hashlib.sha256(fmu.read_bytes()).hexdigest()  # pinned to the build the campaign ran (issue 61)
    assert all(f"--expect-fmu controller={digest}" in c for c in mine), commands
    os.chdir(tmp_path)
    argv = shlex.split(mine[0])[1:] + ["--fmus", str(fmus), "--no-log", "--quiet", "--no-plots"]
    assert main(argv) == 0, capsys.readouterr().err
    kept = fmu.read_bytes()
    try:  # another build at the same path: the rerun refuses it in one line rather than rerunning another controller
        with zipfile.ZipFile(fmu, "a") as rebuilt:  # the same controller, another build: its digest differs
            rebuilt.writestr("documentation/rebuilt.txt", "rebuilt")
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "is not the FMU expected" in err[0], err
    finally:
        fmu.write_bytes(kept)


# ====================================================================================================================
# Issue 49, what a new user hit.
# ====================================================================================================================

def _metric_lines(out: str) -> list[str]:
    return [ln for ln in out.splitlines() if ln.strip().startswith(("ISE(", "IADU("))]


@pytest.mark.slow
def test_a_snapshot_at_the_stop_time_saves_the_end_state_and_continues_as_the_whole_run(fmus, tmp_path, capsys):
    """--stop-time 1 --snapshot-at 1 (the run's end state) is taken; continued to 1.5 s, its metrics are the
    uninterrupted 1.5 s run's, digit for digit."""
    common = ["--fmus", str(fmus), "--no-log", "--no-plots", "--scenario", "fsi", "--controller", "dlqr"]
    end = tmp_path / "end.snapshot"
    assert main(["run", "--stop-time", "1", "--snapshot-at", "1", str(end), *common]) == 0
    assert end.is_file() and "snapshot at t = 0.996 s:" in capsys.readouterr().out  # the last tick, 83 x 12 ms
    assert main(["run", "--from-snapshot", str(end), "--stop-time", "1.5", "--fmus", str(fmus), "--no-log", "--no-plots"]) == 0
    continued = _metric_lines(capsys.readouterr().out)
    assert main(["run", "--stop-time", "1.5", *common]) == 0
    whole = _metric_lines(capsys.readouterr().out)
    assert continued and continued == whole
    assert main(["run", "--stop-time", "1", "--snapshot-at", "1.012", str(tmp_path / "late.snapshot"), *common]) == 2
    assert "0 < T <= 1 s" in capsys.readouterr().err


@pytest.mark.slow
def test_a_controller_whose_init_raises_is_refused_when_wrapped_once(tmp_path, capfd):
    """A class whose __init__ raises is refused by `tiltload wrap` at once, its error named once with its line, and no
    FMU written (until issue 62 it wrapped with exit 0 and every evaluation of a search failed on it instead)."""
    src = tmp_path / "initbad.py"
    src.write_text("class InitBad:\n    inputs = ['x_ref']\n\n    def __init__(self):\n        raise KeyError('x_ref_gain')\n\n"
                   "    def step(self, t, i):\n        return 10.0, 10.0, 0.0, 0.0\n")
    capfd.readouterr()
    assert main(["wrap", str(src), "--out", str(tmp_path / "initbad.fmu")]) == 2
    err = [line for line in capfd.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and "KeyError ('x_ref_gain')" in err[0] and "line 5" in err[0] and "Traceback" not in err[0], err
    assert not (tmp_path / "initbad.fmu").exists()


def test_the_pytest_plugin_prints_a_baseline_report_once(tmp_path):
    """A user's test whose run is off its baseline fails with the report printed once: pytest's own output of that
    test holds the report's first line once and no "During handling of the above exception"."""
    import subprocess
    import sys

    (tmp_path / "baselines" / "test_user").mkdir(parents=True)
    (tmp_path / "baselines" / "test_user" / "test_off.json").write_text(
        json.dumps({"metrics": {"ISE(x)": 0.5, "IADU(f_R)": 2.0}, "tolerances": {"rtol": 1e-6, "atol": 1e-12}}))
    (tmp_path / "pytest.ini").write_text("[pytest]\ntiltload_baselines = baselines\n")
    (tmp_path / "test_user.py").write_text(
        "import tiltload as tl\nfrom tiltload.master.app.case.record import record\n\n"
        "def test_off(tiltload_baseline):\n"
        "    case = {k: str(v) for k, v in record(scenario='zse', trajectory=1, controller='mixed', seed=1, stop_time=40.0).items()}\n"
        "    result = tl.Result(metrics={'ISE(x)': 0.55, 'IADU(f_R)': 2.0}, case=None, options=None, record=case, log=None,\n"
        "                       command='tiltload run', stop_time=40.0, sim_time=40.0, wall_time=1.0, ticks=3333)\n"
        "    tiltload_baseline.check(result)\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_ADDOPTS"}
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_user.py"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 1, done.stdout[-3000:]
    failures = done.stdout.split("short test summary info")[0]  # pytest repeats a failure's message there (in CI, whole)
    assert failures.count("the run differs from its baseline: 1 of 2 metrics out of tolerance\n") == 1, done.stdout
    assert "During handling of the above exception" not in done.stdout, done.stdout


@pytest.mark.slow
def test_run_prints_the_thesis_values_beside_its_metrics_as_readme_says(fmus, tmp_path, capsys):
    """FSI, trajectory 1, DLQR, 40 s: the column of the thesis's Table 5.4 (values typed from the thesis); cut short, a
    note; another case (a --set), no column."""
    common = ["--fmus", str(fmus), "--no-log", "--no-plots", "--quiet", "--scenario", "fsi", "--controller", "dlqr"]
    assert main(["run", *common]) == 0
    out = capsys.readouterr().out.splitlines()
    assert any(ln.split() == ["metric", "value", "thesis", "(Table", "5.4)"] for ln in out), out
    rows = {ln.split()[0]: ln.split()[1:] for ln in out if ln.strip().startswith(("ISE(", "IADU("))}
    assert float(rows["ISE(x)"][1]) == 0.1571 and float(rows["IADU(tau_L)"][1]) == 0.1982, rows
    assert main(["run", *common, "--stop-time", "2"]) == 0
    assert "note: the thesis's values (Table 5.4) are of the whole 40 s run" in capsys.readouterr().out
    assert main(["run", *common, "--stop-time", "40", "--set", "plant.m_L=0.06"]) == 0
    out = capsys.readouterr().out
    assert "thesis (" not in out and "note: the thesis" not in out


def test_the_plugins_report_path_is_checked_before_any_test_runs(tmp_path):
    """--tiltload-report naming a folder, a path under a file or a FIFO: pytest's one usage line (exit 4) before the
    session, not a traceback at its end after every test ran."""
    import subprocess
    import sys

    (tmp_path / "test_user.py").write_text("def test_a():\n    pass\n")
    (tmp_path / "a_file").write_text("x")
    os.mkfifo(tmp_path / "a_fifo")
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_ADDOPTS"}
    for path, says in ((tmp_path, "is a folder, not a file"), (tmp_path / "a_file" / "r.html", "so no file can be made"),
                       (tmp_path / "a_fifo", "is a FIFO, not a file")):
        done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_user.py",
                               f"--tiltload-report={path}"], cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
        lines = [ln for ln in (done.stdout + done.stderr).splitlines() if ln.strip()]
        assert done.returncode == 4 and len(lines) == 1 and says in lines[0] and "passed" not in done.stdout, lines
