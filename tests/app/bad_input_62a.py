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
    for k, tk in enumerate(t):
        batch.add(channel, int(round(tk * 1e9)), enc.encode(float(tk), np.array([np.sin(tk), -2.0]), np.zeros(0, np.int32),
                                                           np.zeros(0, bool)))
    w.add_messages(batch)
    w.close()
    return Path(path)


def writer_cases(folder: Path, log: Path) -> list[tuple]:
    """tl.save_baseline, tl.save_signal_baseline, tl.b2b(out=...) onto places no file can be written, or onto the
    log they read."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "a_file").write_text("x")
    fifo = folder / "fifo"
    if not fifo.exists():
        os.mkfifo(fifo)
    copy = log_with_metrics(folder / "own.mcap")
    link = folder / "link.mcap"
    if not link.is_symlink():
        link.symlink_to(copy)
    places = {"a FIFO": fifo, "a folder": folder, "under a file": folder / "a_file" / "b.json", "/dev/null": Path("/dev/null"),
              "its own log": copy, "a link to its own log": link, "its own log by another path": folder / ".." / folder.name / "own.mcap",
              "an empty path": Path("")}
    cases = []
    for label, where in places.items():
        target = "''" if label == "an empty path" else repr(str(where))
        cases.append((WRITERS, f"tl.save_baseline onto {label}", None, f"tl.save_baseline({str(copy)!r}, {target})", "2"))
        cases.append((WRITERS, f"tl.save_signal_baseline onto {label}", None,
                      f"tl.save_signal_baseline({str(copy)!r}, {target}, ['plant.x'])", "2"))
    for label, where in (("a file", folder / "a_file"), ("a FIFO", fifo), ("under a file", folder / "a_file" / "out"),
                         ("an empty path", "")):
        cases.append((WRITERS, f"tl.b2b(out=) {label}", None,
                      f"tl.b2b([{{'scenario': 'fsi', 'trajectory': 1, 'stop_time': 0.1}}], out={str(where)!r})", "2"))
    cases.append((WRITERS, "compare --save onto its own log", None, f"tl.save_baseline({str(copy)!r}, {str(copy)!r})", "2"))
    return cases
