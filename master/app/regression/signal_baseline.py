"""A signal baseline: chosen signals of a run as one Parquet file (zstd), its header a small JSON document in the file's
key-value metadata (the case, the FMUs' record, each signal's tolerances and unit). Long format: one row a sample,
(signal, t, value), the signal's name dictionary-encoded; readable by any Parquet reader (pandas, polars, DuckDB).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...engine.errors import DescriptionError

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
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # the header once, in the file's key-value metadata (store_schema would copy it again, base64, into the Arrow
    # schema); floats split by byte, which zstd compresses better
    with pq.ParquetWriter(path, table.schema, compression="zstd", compression_level=9, store_schema=False,
                          use_byte_stream_split=["t", "value"]) as writer:
        writer.write_table(table)
        writer.add_key_value_metadata({KEY.decode(): json.dumps({"format": FORMAT, **header})})
    return path


def _checked(path: Path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise DescriptionError(f"{path} does not exist")
    if path.stat().st_size > MAX_BYTES:
        raise DescriptionError(f"{path}: {path.stat().st_size} bytes, more than a signal baseline may be ({MAX_BYTES})")
    return path


def read_header(path: Path) -> dict:
    """The baseline's header (the case "run", "fmus", "tolerances", "units", "signals")."""
    import pyarrow.parquet as pq

    path = _checked(path)
    try:
        meta = pq.read_schema(path).metadata or {}
    except Exception as err:  # pyarrow's errors: any unreadable file is the user's to fix
        raise DescriptionError(f"{path} is not a signal baseline (not a Parquet file: {str(err).splitlines()[0]})") from None
    try:
        header = json.loads(meta[KEY])
    except (KeyError, ValueError):
        raise DescriptionError(f"{path} is not a signal baseline (a Parquet file without tiltload's header)") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise DescriptionError(f"{path} is not a signal baseline of this tiltload (format {header.get('format')!r})")
    return header


def read(path: Path) -> tuple[dict, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """(header, {signal: (times, values)}) in the file's order."""
    import pyarrow.parquet as pq

    header = read_header(path)
    try:
        table = pq.read_table(path)
        codes = table.column("signal").combine_chunks().dictionary_encode()
        names = [str(n) for n in codes.dictionary.to_pylist()]
        index = codes.indices.to_numpy(zero_copy_only=False)
        t = table.column("t").to_numpy()
        y = table.column("value").to_numpy()
    except Exception as err:
        raise DescriptionError(f"{path} is damaged ({str(err).splitlines()[0]})") from None
    return header, {n: (t[index == i], y[index == i]) for i, n in enumerate(names)}
