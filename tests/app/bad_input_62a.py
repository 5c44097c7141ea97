"""Generators of issue 62's bad inputs (part A): malformed baselines, writers pointed at bad places or at their own
inputs, b2b's case lists and sides, read-only output places. Each returns (class, label, argv or None, API code or
None, expected exit) as test_bad_input.surface_cases does; the tests (test_bad_input_62a.py) and the census
(benchmarks/bad_input_census.py) run the same cases."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

FORMAT = "tiltload signal baseline 1"
BASELINES = "baselines: malformed headers and tables"
WRITERS = "API writers: path checks, inputs as outputs"
B2B = "b2b: case lists and sides"
READ_ONLY = "read-only output places"
REPORTS = "reports: an input as the report"


def write_parquet(path: Path, header: object | bytes | None, names=("plant.x", "plant.z"), rows: int = 201,
                  columns: dict | None = None) -> Path:
    """A Parquet file as signal_baseline.write lays it out (signal, t, value) with this header (any JSON value, raw
    bytes, or None: no tiltload key); columns: replace or add columns (pyarrow arrays)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = np.arange(rows) * 0.01
    signal = pa.DictionaryArray.from_arrays(pa.array(np.repeat(np.arange(len(names), dtype=np.int32), rows)),
                                            pa.array(list(names), type=pa.string()))
    table = {"signal": signal, "t": pa.array(np.tile(t, len(names))),
             "value": pa.array(np.concatenate([np.sin(t) if n == "plant.x" else -2 + 0 * t for n in names]) if names else [],
                               type=pa.float64())}
    if not names:
        table["signal"] = pa.array([], pa.string())
        table["t"] = pa.array([], pa.float64())
    table.update(columns or {})
    table = {k: v for k, v in table.items() if v is not None}
    arrow = pa.table(table)
    with pq.ParquetWriter(path, arrow.schema, store_schema=False) as writer:
        writer.write_table(arrow)
        if header is not None:
            raw = header if isinstance(header, bytes) else json.dumps(header).encode()
            writer.add_key_value_metadata({"tiltload": raw})
    return Path(path)


def good_header(**changes) -> dict:
    header = {"format": FORMAT, "run": {"stop_time": "2.0"}, "fmus": {}, "units": {"plant.x": "m"},
              "tolerances": {"default": {"abs": 1e-12, "rel": 1e-6, "lead": 0.0, "lag": 0.0}, "signals": {}},
              "signals": ["plant.x", "plant.z"]}
    header.update(changes)
    return {k: v for k, v in header.items() if v is not _DROP}


_DROP = object()


def _deep(levels: int) -> object:
    value: object = 1
    for _ in range(levels):
        value = {"a": value}
    return value


def bad_headers() -> dict[str, object]:
    """label -> a header (or raw bytes) no baseline may have."""
    return {
        "run a list": good_header(run=["fsi", 1]), "run text": good_header(run="fsi"), "run nested": good_header(run={"seed": {"a": 1}}),
        "run 40 levels deep": good_header(run=_deep(40)), "run of 300 keys": good_header(run={f"k{i}": 1 for i in range(300)}),
        "run key of 5000 characters": good_header(run={"k" * 5000: 1}),
        "run value of 100,000 characters": good_header(run={"a": "x" * 100_000}),
        "run value null": good_header(run={"seed": None}), "run key with a newline": good_header(run={"se\ned": 1}),
        "fmus a number": good_header(fmus=3), "fmus values numbers": good_header(fmus={"plant.sha256": 12}),
        "fmus nested": good_header(fmus={"plant": {"sha256": "ab"}}), "fmus a list of lists": good_header(fmus=[[1]]),
        "units a list": good_header(units=["m"]), "units a number for a unit": good_header(units={"plant.x": 1}),
        "units keyed by no signal": good_header(units={"x": "m"}),
        "units a unit of 1000 characters": good_header(units={"plant.x": "m" * 1000}),
        "tolerances text": good_header(tolerances="tight"), "tolerances abs text": good_header(tolerances={"default": {"abs": "1"}}),
        "tolerances negative": good_header(tolerances={"default": {"rel": -1}}),
        "tolerances an unknown key": good_header(tolerances={"default": {"absolute": 1}}),
        "tolerances of a signal not instance.variable": good_header(tolerances={"signals": {"x": {"abs": 1}}}),
        "signals empty": good_header(signals=[]), "signals numbers": good_header(signals=[1, 2]),
        "signals text": good_header(signals="plant.x"), "signals named without a dot": good_header(signals=["x", "z"]),
        "signals twice": good_header(signals=["plant.x", "plant.x"]),
        "signals other than the samples'": good_header(signals=["plant.y", "plant.z"]),
        "format a number": good_header(format=1), "format null": good_header(format=None), "format missing": good_header(format=_DROP),
        "an unknown key": good_header(extra=1), "header a list": [FORMAT], "header a number": 1, "header null": None,
        "header not JSON": b"{format", "header not UTF-8": b"\xff\xfe{}",
        "header NaN": b'{"format": "%s", "run": {"a": NaN}}' % FORMAT.encode(),
        "header 1e999": b'{"format": "%s", "run": {"a": 1e999}}' % FORMAT.encode(),
        "header an integer of 5000 digits": b'{"format": "%s", "run": {"a": %s}}' % (FORMAT.encode(), b"9" * 5000),
        "header 100,000 levels deep": b"[" * 100_000 + b"]" * 100_000,
    }


def bad_tables() -> dict[str, dict]:
    """label -> write_parquet's keyword arguments for a table no baseline may have (the header good)."""
    import pyarrow as pa

    n = 201
    return {
        "no rows": {"names": (), "header": good_header(signals=_DROP)},
        "times as text": {"columns": {"t": pa.array([str(i) for i in range(2 * n)])}},
        "values as text": {"columns": {"value": pa.array(["1"] * (2 * n))}},
        "values as booleans": {"columns": {"value": pa.array([True] * (2 * n))}},
        "signal as numbers": {"columns": {"signal": pa.array([1] * (2 * n))}, "header": good_header(signals=_DROP)},
        "no time column": {"columns": {"t": None}},
        "no signal column": {"columns": {"signal": None}},
        "a signal named without a dot": {"names": ("x", "plant.z"), "header": good_header(signals=_DROP)},
        "a signal name with a newline": {"names": ("plant.x\nplant.y", "plant.z"), "header": good_header(signals=_DROP)},
        "a NaN time": {"columns": {"t": pa.array([float("nan")] * (2 * n))}},
        "times going back": {"columns": {"t": pa.array(np.tile(np.arange(n)[::-1] * 0.01, 2))}},
        "a sample without a signal": {"columns": {"signal": pa.array([None] * (2 * n), pa.string())}, "header": good_header(signals=_DROP)},
        "no tiltload header": {"header": None},
    }


def bad_metric_baselines() -> dict[str, object]:
    """label -> a metrics baseline (.json) document no baseline may have."""
    return {
        "run a list": {"metrics": {"ISE_x": 1.0}, "run": [1]}, "run nested": {"metrics": {"ISE_x": 1.0}, "run": {"a": {"b": 1}}},
        "fmus values numbers": {"metrics": {"ISE_x": 1.0}, "fmus": {"plant.sha256": 1}}, "fmus text": {"metrics": {"ISE_x": 1.0},
        "fmus": "x"},
        "metrics text": {"metrics": {"ISE_x": "1"}}, "metrics empty": {"metrics": {}},
        "metric named with a newline": {"metrics": {"a\nb": 1.0}},
        "metrics a list": {"metrics": [1.0]}, "a document a list": [{"metrics": {}}], "tolerances text": {"metrics": {"ISE_x": 1.0},
        "tolerances": "x"},
        "run key of 5000 characters": {"metrics": {"ISE_x": 1.0}, "run": {"k" * 5000: "1"}},
    }


def baseline_cases(folder: Path, log: Path) -> list[tuple]:
    """compare (the command) and tl.compare_signals / tl.compare (the API) on each malformed baseline."""
    folder.mkdir(parents=True, exist_ok=True)
    cases = []
    files = []
    for i, (label, header) in enumerate(bad_headers().items()):
        files.append((f"header: {label}", write_parquet(folder / f"h{i}.parquet", header)))
    for i, (label, kwargs) in enumerate(bad_tables().items()):
        kwargs = dict(kwargs)
        files.append((f"table: {label}", write_parquet(folder / f"t{i}.parquet", kwargs.pop("header", good_header()), **kwargs)))
    for label, path in files:
        cases.append((BASELINES, f"compare, {label}", ["compare", str(log), str(path)], None, "2"))
        cases.append((BASELINES, f"tl.compare_signals, {label}", None, f"tl.compare_signals({str(log)!r}, {str(path)!r})", "2"))
    run = folder / "run.json"  # a run's metrics as a file: the baseline's problems are reached, not the run's
    run.write_text(json.dumps({"metrics": {"ISE_x": 1.0}}))
    for i, (label, doc) in enumerate(bad_metric_baselines().items()):
        path = folder / f"m{i}.json"
        path.write_text(json.dumps(doc))
        cases.append((BASELINES, f"compare, metrics file: {label}", ["compare", str(run), str(path)], None, "2"))
        cases.append((BASELINES, f"tl.compare, metrics file: {label}", None, f"tl.compare({str(run)!r}, {str(path)!r})", "2"))
    return cases


def log_with_metrics(path: Path) -> Path:
    """A run's log as tiltload writes one (its run and metrics records), of two plant signals."""
    from tiltload.master.engine.log.encoding import LAYOUT, FixedMessage
    from tiltload.master.engine.log.writer import McapWriter, MessageBatch

    w = McapWriter(Path(path))
    w.add_metadata("run", {"scenario": "fsi", "trajectory": "1", "controller": "dlqr", "seed": "1", "stop_time": "2.0"})
    w.add_metadata("metrics", {"ISE_x": "0.5", "IADU_f": "1.5", "ticks": "200", "complete": "True"})
    t = np.arange(201) * 0.01
    enc = FixedMessage("plant", ["x", "z"], [], [])
    channel = w.add_channel("/plant", w.add_schema(enc.full_name, "protobuf", enc.schema()), "protobuf", {"layout": LAYOUT})
    batch = MessageBatch()
    for tk in t:
        batch.add(channel, int(round(tk * 1e9)), enc.encode(float(tk), np.array([np.sin(tk), -2.0]), np.zeros(0, np.int32),
                                                           np.zeros(0, bool)))
    w.add_messages(batch)
    w.close()
    return Path(path)


def _own_inputs(where: Path) -> tuple[Path, Path, Path, Path]:
    """A folder of a case's own: (a run's log, a relative link to it, a hard link to it, a requirement file). Each case
    has its own, so that an input one tiltload wrote over cannot decide how the next case ends."""
    where.mkdir(parents=True, exist_ok=True)
    log = log_with_metrics(where / "a.mcap")
    link, hard, reqs = where / "link.mcap", where / "hard.mcap", where / "r.yaml"
    if not link.is_symlink():
        link.symlink_to(log.name)  # relative: a copy of the folder (the census's) keeps it pointing at its own log
    if not hard.exists():
        os.link(log, hard)
    reqs.write_text(REQS)
    return log, link, hard, reqs


def writer_cases(folder: Path, log: Path) -> list[tuple]:
    """tl.save_baseline, tl.save_signal_baseline, tl.b2b(out=...) onto places no file can be written, or onto the
    log they read (each case with its own log)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "a_file").write_text("x")
    fifo = folder / "fifo"
    if not fifo.exists():
        os.mkfifo(fifo)
    places = {"a FIFO": lambda d, own: fifo, "a folder": lambda d, own: d, "under a file": lambda d, own: folder / "a_file" / "b.json",
              "/dev/null": lambda d, own: Path("/dev/null"), "its own log": lambda d, own: own[0],
              "a link to its own log": lambda d, own: own[1], "its own log by another path": lambda d, own: d / ".." / d.name / "a.mcap",
              "an empty path": lambda d, own: Path("")}
    cases = []
    for i, (label, place) in enumerate(places.items()):
        for writer, extra in (("tl.save_baseline", ""), ("tl.save_signal_baseline", ", ['plant.x']")):
            where = folder / f"{writer[3:]}{i}"
            own = _own_inputs(where)
            target = "''" if label == "an empty path" else repr(str(place(where, own)))
            cases.append((WRITERS, f"{writer} onto {label}", None, f"{writer}({str(own[0])!r}, {target}{extra})", "2"))
    for label, where in (("a file", folder / "a_file"), ("a FIFO", fifo), ("under a file", folder / "a_file" / "out"),
                         ("an empty path", "")):
        cases.append((WRITERS, f"tl.b2b(out=) {label}", None,
                      f"tl.b2b([{{'scenario': 'fsi', 'trajectory': 1, 'stop_time': 0.1}}], out={str(where)!r})", "2"))
    log, _, hard, _ = _own_inputs(folder / "record")
    json_link = folder / "record" / "b.json"
    if not json_link.exists():
        os.link(log, json_link)  # a baseline's name that is the log itself (a hard link)
    cases.append((WRITERS, "compare --record-baseline onto a hard link of its log", ["compare", str(log), str(json_link),
                                                                                     "--record-baseline"], None, "2"))
    return cases


def _case_list_api(cases: str, fmus: Path, out: Path, **sides: str) -> str:
    given = "".join(f", {k}={v}" for k, v in sides.items())
    return (f"tl.b2b({cases}, reference={{'fmus': {str(fmus)!r}}}{given or f', candidate={{{chr(39)}fmus{chr(39)}: {str(fmus)!r}}}'}"
            f", out={str(out)!r})")


def b2b_cases(folder: Path, fmus: Path) -> list[tuple]:
    """tl.b2b's case lists and sides, and the command's sides that do not start: each refused in one line before any
    run (the case list file's schema, run's checks of --set and of a controller FMU)."""
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / "out"
    one = "'scenario': 'fsi', 'trajectory': 1, 'stop_time': 0.2"
    cases = []
    lists = {"stop time 1e300": "[{'scenario': 'fsi', 'trajectory': 1, 'stop_time': 1e300}]",
             "stop time NaN": "[{'scenario': 'fsi', 'trajectory': 1, 'stop_time': float('nan')}]",
             "stop time inf": "[{'scenario': 'fsi', 'trajectory': 1, 'stop_time': float('inf')}]",
             "stop time text": "[{'scenario': 'fsi', 'trajectory': 1, 'stop_time': '1'}]",
             "an unknown scenario": "[{'scenario': 'ekf', 'trajectory': 1}]", "a scenario a number": "[{'scenario': 3, 'trajectory': 1}]",
             "trajectory 9": "[{'scenario': 'fsi', 'trajectory': 9}]", "trajectory True": "[{'scenario': 'fsi', 'trajectory': True}]",
             "controller pid": f"[{{{one}, 'controller': 'pid'}}]", "seed -1": f"[{{{one}, 'seed': -1}}]",
             "seed 2**40": f"[{{{one}, 'seed': 2**40}}]", "an unknown key": f"[{{{one}, 'bogus': 1}}]",
             "a key not text": f"[{{{one}, 1: 2}}]", "no trajectory": "[{'scenario': 'fsi'}]",
             "B2BCase of an unknown scenario": "[tl.B2BCase('nowhere', 1)]",
             "B2BCase stop time NaN": "[tl.B2BCase('fsi', 1, stop_time=float('nan'))]",
             "B2BCase stop time 1e300": "[tl.B2BCase('fsi', 1, stop_time=1e300)]",
             "B2BCase seed text": "[tl.B2BCase('fsi', 1, seed='1')]"}
    for label, given in lists.items():
        cases.append((B2B, f"tl.b2b case list: {label}", None, _case_list_api(given, fmus, out), "2"))
    good = f"[{{{one}}}]"
    fm = str(fmus)
    sides = {"a NaN gain": f"{{'fmus': {fm!r}, 'stage': 'mil', 'gain': (0, 0, float('nan'))}}",
             "an infinite gain": f"{{'fmus': {fm!r}, 'stage': 'mil', 'gain': (0, 0, float('inf'))}}",
             "a gain of text": f"{{'fmus': {fm!r}, 'stage': 'mil', 'gain': 'abc'}}",
             "a gain of one number": f"{{'fmus': {fm!r}, 'stage': 'mil', 'gain': (0,)}}",
             "a gain entry out of K": f"{{'fmus': {fm!r}, 'stage': 'mil', 'gain': (99, 0, 1.0)}}",
             "a gain of a negative entry": f"{{'fmus': {fm!r}, 'stage': 'mil', 'gain': (-1, 0, 1.0)}}",
             "a gain of text entries": f"{{'fmus': {fm!r}, 'stage': 'mil', 'gain': ('a', 'b', 'c')}}",
             "an unknown parameter": f"{{'fmus': {fm!r}, 'settings': {{'plant.nothing': 1}}}}",
             "a parameter of text": f"{{'fmus': {fm!r}, 'settings': {{'controller.Tc': 'abc'}}}}",
             "a NaN parameter": f"{{'fmus': {fm!r}, 'settings': {{'plant.m_L': float('nan')}}}}",
             "a parameter of no instance": f"{{'fmus': {fm!r}, 'settings': {{'nothing.x': 1}}}}",
             "a controller a number": f"{{'fmus': {fm!r}, 'controller': 3}}",
             "a stage xil": f"{{'fmus': {fm!r}, 'stage': 'xil'}}", "fmus a number": "{'fmus': 3}"}
    for label, side in sides.items():
        cases.append((B2B, f"tl.b2b candidate: {label}", None, _case_list_api(good, fmus, out, candidate=side), "2"))
    case_file = folder / "one.toml"
    case_file.write_text('cases = [{scenario = "fsi", trajectory = 1, stop_time = 0.2}]\n')
    not_a_controller = fmus / "TiltloadPlant.fmu"
    base = ["b2b", "--cases", str(case_file), "--reference-fmus", str(fmus), "--candidate-fmus", str(fmus), "--out", str(out)]
    for label, extra in {"--candidate-set of an unknown parameter": ["--candidate-set", "plant.nothing=1"],
                         "--candidate-set of text for a Real": ["--candidate-set", "controller.Tc=abc"],
                         "--candidate-set of no instance": ["--candidate-set", "nothing.x=1"],
                         "--candidate-set nan": ["--candidate-set", "plant.m_L=nan"],
                         "--reference-set of an output": ["--reference-set", "plant.x=1"],
                         "--candidate-controller the plant's FMU": ["--candidate-controller", str(not_a_controller)]}.items():
        cases.append((B2B, f"b2b {label}", [*base, *extra], None, "2"))
    return cases


REQS = "requirements:\n  - name: low\n    formula: plant.z < 5\n"
CONTROLLER = ("class C:\n    inputs = ['x_ref', 'x']\n    def step(self, t, i):\n        return 0.0, 0.0, 0.0, 0.0\n")


def readonly_mount(where: Path) -> Path | None:
    """A read-only tmpfs at where holding a log (a.mcap) and a requirement file (r.yaml); None where this machine does not
    let us mount (then the read-only cases are left out). Mounted once: a second call finds it."""
    import subprocess

    where.mkdir(parents=True, exist_ok=True)
    if (where / "a.mcap").is_file():
        return where
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(where)], capture_output=True).returncode:
        return None
    log_with_metrics(where / "a.mcap")
    (where / "r.yaml").write_text(REQS)
    subprocess.run(["mount", "-o", "remount,ro", str(where)], check=True)
    return where


def readonly_cases(folder: Path, fmus: Path, ro: Path) -> list[tuple]:
    """Every writer onto a read-only disk: one line, exit 2, before any work."""
    folder.mkdir(parents=True, exist_ok=True)
    source = folder / "ctrl.py"
    source.write_text(CONTROLLER)
    log, reqs = ro / "a.mcap", ro / "r.yaml"
    fm = str(fmus)
    b2b = ["b2b", "--cases", str(folder / "one.toml"), "--reference-fmus", fm, "--candidate-fmus", fm]
    (folder / "one.toml").write_text('cases = [{scenario = "fsi", trajectory = 1, stop_time = 0.2}]\n')
    run = ["run", "--scenario", "fsi", "--stop-time", "0.2", "--fmus", fm, "--out", str(folder / "runs"), "--quiet", "--no-plots"]
    cases = []
    for where, label in ((ro, "a read-only disk"), (ro / "sub" / "deeper", "a folder to make on a read-only disk")):
        argvs = {"check --report": ["check", str(reqs), str(log), "--report", str(where / "r.html")],
                 "b2b --out": [*b2b, "--out", str(where / "b2b")],
                 "wrap --out": ["wrap", str(source), "--out", str(where / "w.fmu")],
                 "wrap --native --out": ["wrap", "--native", str(source), "--out", str(where / "n.fmu")],
                 "run --report": [*run, "--report", str(where / "r.html")],
                 "compare --record-baseline (.json)": ["compare", str(log), str(where / "b.json"), "--record-baseline"],
                 "compare --record-baseline (.parquet)": ["compare", str(log), str(where / "b.parquet"), "--record-baseline",
                                                          "--signals", "plant.x"]}
        for name, argv in argvs.items():
            cases.append((READ_ONLY, f"{name} on {label}", argv, None, "2"))
        apis = {"tl.save_baseline": f"tl.save_baseline({str(log)!r}, {str(where / 'b.json')!r})",
                "tl.save_signal_baseline": f"tl.save_signal_baseline({str(log)!r}, {str(where / 'b.parquet')!r}, ['plant.x'])",
                "tl.b2b(out=)": f"tl.b2b([{{'scenario': 'fsi', 'trajectory': 1, 'stop_time': 0.2}}], reference={{'fmus': {fm!r}}}, "
                                f"candidate={{'fmus': {fm!r}}}, out={str(where / 'b2b')!r})",
                "tl.run(report=)": f"tl.run(tl.Case(stop_time=0.2, fmus={fm!r}), tl.RunOptions(out={str(folder / 'runs')!r}, "
                                   f"quiet=True, no_plots=True, report={str(where / 'r.html')!r}))"}
        for name, code in apis.items():
            cases.append((READ_ONLY, f"{name} on {label}", None, code, "2"))
    return cases


def report_cases(folder: Path, fmus: Path) -> list[tuple]:
    """A report pointed at one of its command's inputs: refused in one line, the input unchanged (the tests compare
    its bytes; the census counts the line). Each case with its own inputs (_own_inputs)."""
    folder.mkdir(parents=True, exist_ok=True)
    fm = str(fmus)

    def run(d: Path) -> list[str]:
        return ["run", "--scenario", "fsi", "--stop-time", "0.2", "--fmus", fm, "--out", str(d / "runs"), "--quiet", "--no-plots"]

    made = {name: (folder / name, *_own_inputs(folder / name)) for name in
            ("log", "reqs", "link", "hard", "path", "second", "run_reqs", "run_log", "api")}
    d, log, link, hard, reqs = made["log"]
    cases = [(REPORTS, "check --report the log it judges", ["check", str(reqs), str(log), "--report", str(log)], None, "2")]
    d, log, link, hard, reqs = made["reqs"]
    cases.append((REPORTS, "check --report the requirement file", ["check", str(reqs), str(log), "--report", str(reqs)], None, "2"))
    d, log, link, hard, reqs = made["link"]
    cases.append((REPORTS, "check --report a link to the log", ["check", str(reqs), str(log), "--report", str(link)], None, "2"))
    d, log, link, hard, reqs = made["hard"]
    cases.append((REPORTS, "check --report a hard link to the log", ["check", "--formula", "a: plant.z < 5", str(log),
                                                                    "--report", str(hard)], None, "2"))
    d, log, link, hard, reqs = made["path"]
    cases.append((REPORTS, "check --report the log by another path", ["check", str(reqs), str(log), "--report",
                                                                      str(d / ".." / d.name / "a.mcap")], None, "2"))
    d, log, link, hard, reqs = made["second"]
    second = log_with_metrics(d / "second.mcap")
    cases.append((REPORTS, "check --report the second log", ["check", str(reqs), str(log), str(second), "--report", str(second)],
                  None, "2"))
    d, log, link, hard, reqs = made["run_reqs"]
    cases.append((REPORTS, "run --report its requirement file", [*run(d), "--requirements", str(reqs), "--report", str(reqs)],
                  None, "2"))
    d, log, link, hard, reqs = made["run_log"]
    cases.append((REPORTS, "run --report its own log", [*run(d), "--name", "own", "--report", str(d / "runs" / "own.mcap")],
                  None, "2"))
    d, log, link, hard, reqs = made["api"]
    cases.append((REPORTS, "tl.run(report=) its requirement file", None,
                  f"tl.run(tl.Case(stop_time=0.2, fmus={fm!r}), tl.RunOptions(out={str(d / 'runs')!r}, quiet=True, "
                  f"no_plots=True, requirements={str(reqs)!r}, report={str(reqs)!r}))", "2"))
    from test_bad_input import CAMPAIGN_SPEC, FALSIFY_SPEC

    specs = {"campaign": CAMPAIGN_SPEC, "falsify": FALSIFY_SPEC}
    for command in ("campaign", "falsify"):
        out = folder / f"{command}_out"
        out.mkdir(exist_ok=True)
        spec = folder / f"{command}.toml"
        spec.write_text(specs[command])  # a spec that runs: the old tiltload ran it and wrote its report
        if not (out / "report.html").is_symlink():
            (out / "report.html").symlink_to(Path("..") / spec.name)
        cases.append((REPORTS, f"{command}: its report.html a link to its spec", [command, str(spec), "--out", str(out),
                                                                                 "--fmus", fm, "--workers", "1"], None, "2"))
    return cases
