"""A signal baseline: chosen signals of a run as one Parquet file (zstd), its header a small JSON document in the file's
key-value metadata (the case, the FMUs' record, each signal's tolerances and unit). Long format: one row a sample,
(signal, t, value), the signal's name dictionary-encoded; readable by any Parquet reader (pandas, polars, DuckDB).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...engine.errors import DescriptionError
from .baseline_schema import FMUS, MAX_KEYS, RUN, SIGNAL_NAME, TOLERANCES, UNITS, checked

FORMAT = "tiltload signal baseline 1"
KEY = b"tiltload"
MAX_BYTES = 256 * 2**20  # a baseline read is bounded: 100 signals of 10^5 samples compress to a few MB


def write(path: Path, signals: dict[str, tuple[np.ndarray, np.ndarray]], header: dict) -> Path:
    """signals: {"instance.variable": (times, values)}; header: case ("run"), "fmus", "tolerances", "units"."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    names = list(signals)
    codes = np.concatenate([np.full(len(signals[n][0]), i, dtype=np.int32) for i, n in enumerate(names)])
    table = pa.table({
        "signal": pa.DictionaryArray.from_arrays(pa.array(codes), pa.array(names, type=pa.string())),
        "t": pa.array(np.concatenate([np.asarray(signals[n][0], dtype=float) for n in names])),
        "value": pa.array(np.concatenate([np.asarray(signals[n][1], dtype=float) for n in names])),
    })
    # the header once, in the file's key-value metadata (store_schema would copy it again, base64, into the Arrow
    # schema); floats split by byte, which zstd compresses better
    buffer = pa.BufferOutputStream()
    with pq.ParquetWriter(buffer, table.schema, compression="zstd", compression_level=9, store_schema=False,
                          use_byte_stream_split=["t", "value"]) as writer:
        writer.write_table(table)
        writer.add_key_value_metadata({KEY.decode(): json.dumps({"format": FORMAT, **header})})
    from ..output_folder import write_file

    return write_file(Path(path), buffer.getvalue().to_pybytes())  # whole or not at all, a refused write one line


def _checked(path: Path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise DescriptionError(f"{path} does not exist")
    if path.stat().st_size > MAX_BYTES:
        raise DescriptionError(f"{path}: {path.stat().st_size} bytes, more than a signal baseline may be ({MAX_BYTES})")
    return path


HEADER_SCHEMA = {  # what write() puts in the key-value metadata; run, fmus, units, tolerances as every baseline has them
    "type": "object", "required": ["format"], "additionalProperties": False,
    "properties": {"format": {"const": FORMAT}, "run": RUN, "fmus": FMUS, "units": UNITS, "tolerances": TOLERANCES,
                   "signals": {"type": "array", "minItems": 1, "maxItems": MAX_KEYS, "uniqueItems": True,
                               "items": SIGNAL_NAME}},
}
MAX_HEADER = 16 * 2**20  # characters of the header's JSON
MAX_ROWS = 5 * 10**7  # samples (the file is bounded, but zstd packs a constant signal 1000:1)


def read_header(path: Path) -> dict:
    """The baseline's header (the case "run", "fmus", "tolerances", "units", "signals"), checked by HEADER_SCHEMA."""
    import pyarrow.parquet as pq

    path = _checked(path)
    try:
        meta = pq.read_schema(path).metadata or {}
    except Exception as err:  # pyarrow's errors: any unreadable file is the user's to fix
        raise DescriptionError(f"{path} is not a signal baseline (not a Parquet file: {_first_line(err)})") from None
    raw = meta.get(KEY)
    if raw is None:
        raise DescriptionError(f"{path} is not a signal baseline (a Parquet file without tiltload's header)")
    if len(raw) > MAX_HEADER:
        raise DescriptionError(f"{path} is not a signal baseline: its header has {len(raw)} bytes (at most {MAX_HEADER})")
    try:
        header = json.loads(raw)
    except (ValueError, RecursionError):  # ValueError: not JSON, not UTF-8, an integer of thousands of digits
        raise DescriptionError(f"{path} is not a signal baseline (its tiltload header is not JSON)") from None
    if isinstance(header, dict) and header.get("format") != FORMAT and isinstance(header.get("format"), str):
        raise DescriptionError(f"{path} is not a signal baseline of this tiltload (format {header['format'][:80]!r})")
    return checked(header, HEADER_SCHEMA, str(path), "a signal baseline")


def _first_line(err: Exception) -> str:
    return (str(err).splitlines() or [type(err).__name__])[0][:200]


def read(path: Path) -> tuple[dict, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """(header, {signal: (times, values)}) in the file's order: at least one row and one signal, every signal named
    instance.variable and sampled at least once, finite times that never go back, numbers for times and values."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    header = read_header(path)
    try:
        file = pq.ParquetFile(path)
        rows, schema = file.metadata.num_rows, file.schema_arrow
    except Exception as err:
        raise DescriptionError(f"{path} is damaged ({_first_line(err)})") from None
    columns = {f.name: f.type for f in schema}
    for name, kinds in (("signal", "text"), ("t", "numbers"), ("value", "numbers")):
        kind = columns.get(name)
        if kind is None:
            raise DescriptionError(f"{path} is not a signal baseline: it has no column {name!r} (it has signal, t, value)")
        base = kind.value_type if pa.types.is_dictionary(kind) else kind
        fits = (pa.types.is_string(base) or pa.types.is_large_string(base)) if kinds == "text" else (
            pa.types.is_floating(base) or pa.types.is_integer(base))
        if not fits or (kinds == "numbers" and pa.types.is_dictionary(kind)):
            raise DescriptionError(f"{path} is not a signal baseline: its column {name!r} holds {kind}, not {kinds}")
    if rows < 1:
        raise DescriptionError(f"{path} holds no samples: a signal baseline needs at least one signal with one sample")
    if rows > MAX_ROWS:
        raise DescriptionError(f"{path}: {rows} samples, more than a signal baseline may have ({MAX_ROWS})")
    try:
        table = file.read(columns=["signal", "t", "value"])
        codes = table.column("signal").combine_chunks()
        if codes.null_count or table.column("t").null_count:
            raise DescriptionError(f"{path} is damaged (a sample without its signal or time)")
        codes = codes.dictionary_encode() if not pa.types.is_dictionary(codes.type) else codes
        names = [str(n) for n in codes.dictionary.to_pylist()]
        index = codes.indices.to_numpy(zero_copy_only=False)
        t = table.column("t").to_numpy().astype(float)
        y = table.column("value").to_numpy(zero_copy_only=False).astype(float)
    except DescriptionError:
        raise
    except Exception as err:
        raise DescriptionError(f"{path} is damaged ({_first_line(err)})") from None
    used = [i for i in range(len(names)) if np.any(index == i)]
    signals = {names[i]: (t[index == i], y[index == i]) for i in used}
    checked({"signals": list(signals)}, {"properties": {"signals": HEADER_SCHEMA["properties"]["signals"]}}, str(path),
            "a signal baseline")
    if "signals" in header and list(header["signals"]) != list(signals):
        raise DescriptionError(f"{path} is damaged: its header names the signals {', '.join(header['signals'][:6])}, its "
                               f"samples {', '.join(list(signals)[:6])}")
    for name, (times, _) in signals.items():
        if not np.all(np.isfinite(times)) or np.any(np.diff(times) < 0):
            raise DescriptionError(f"{path} is damaged: the times of {name} are not finite and in order")
    return header, signals
