"""Issue 62: every baseline format read by one checked reader. Random malformed metadata (hypothesis) gives a header
that reads or one line of the project's user error, never anything else; each generated malformed baseline is refused
by the command and the API in one line; a good baseline still reads."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from bad_input_62a import FORMAT, bad_headers, bad_metric_baselines, bad_tables, good_header, write_parquet
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tiltload.master.app.regression import signal_baseline
from tiltload.master.app.regression.compare import load_metrics
from tiltload.master.engine.errors import DescriptionError

_SCALARS = (st.none() | st.booleans() | st.integers(-2**70, 2**70) | st.floats(allow_nan=True, allow_infinity=True)
            | st.text(max_size=12))
JSON = st.recursive(_SCALARS, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
                    max_leaves=20)
KEYS = ("format", "run", "fmus", "units", "tolerances", "signals", "other")


def _header_strategy():
    """A header near a good one: each key kept, dropped or given any JSON value."""
    good = good_header()
    return st.fixed_dictionaries({k: st.sampled_from(["keep", "drop"]) | JSON for k in KEYS}).map(
        lambda choice: {k: (good[k] if v == "keep" else v) for k, v in choice.items()
                        if v != "drop" and not (v == "keep" and k not in good)})


def _one_line_refusal(err: DescriptionError, path) -> None:
    text = str(err)
    assert "\n" not in text and str(path) in text and "a bug" not in text, text


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(header=_header_strategy())
def test_random_metadata_reads_or_is_one_line_of_the_user_error(tmp_path, header):
    path = write_parquet(tmp_path / "b.parquet", json.dumps(header, allow_nan=True).encode())
    try:
        read, signals = signal_baseline.read(path)
    except DescriptionError as err:
        _one_line_refusal(err, path)
        return
    # what reads is what a baseline may hold: the format, records of text, two named signals sampled
    assert read["format"] == FORMAT
    assert all(isinstance(v, str) for v in read.get("fmus", {}).values())
    assert all(isinstance(v, (str, int, float)) and not isinstance(v, dict) for v in read.get("run", {}).values())
    assert list(signals) == ["plant.x", "plant.z"] and all(len(t) == 201 for t, _ in signals.values())


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(doc=st.fixed_dictionaries({"metrics": st.dictionaries(st.text(max_size=6), JSON, max_size=3) | JSON},
                                 optional={"run": JSON, "fmus": JSON, "tolerances": JSON}))
def test_random_metrics_files_read_or_are_one_line_of_the_user_error(tmp_path, doc):
    path = tmp_path / "b.json"
    path.write_text(json.dumps(doc, allow_nan=True))
    try:
        metrics, _ = load_metrics(path)
    except DescriptionError as err:
        _one_line_refusal(err, path)
        return
    assert metrics and all(math.isfinite(v) for v in metrics.values())
    assert all(isinstance(v, str) for v in doc.get("fmus", {}).values())


@pytest.mark.parametrize("label", list(bad_headers()))
def test_each_malformed_header_is_refused_in_one_line(tmp_path, label):
    path = write_parquet(tmp_path / "b.parquet", bad_headers()[label])
    with pytest.raises(DescriptionError) as err:
        signal_baseline.read(path)
    _one_line_refusal(err.value, path)


@pytest.mark.parametrize("label", list(bad_tables()))
def test_each_malformed_table_is_refused_in_one_line(tmp_path, label):
    kwargs = dict(bad_tables()[label])
    path = write_parquet(tmp_path / "b.parquet", kwargs.pop("header", good_header()), **kwargs)
    with pytest.raises(DescriptionError) as err:
        signal_baseline.read(path)
    _one_line_refusal(err.value, path)


def test_a_baseline_without_rows_is_refused_not_the_same_within_tolerance(tmp_path):
    """Before: no rows compared as "same within tolerance", exit 0."""
    path = write_parquet(tmp_path / "b.parquet", good_header(signals=["plant.x"]), names=())
    with pytest.raises(DescriptionError, match="no samples"):
        signal_baseline.read(path)


@pytest.mark.parametrize("label", list(bad_metric_baselines()))
def test_each_malformed_metrics_file_is_refused_in_one_line(tmp_path, label):
    path = tmp_path / "b.json"
    path.write_text(json.dumps(bad_metric_baselines()[label]))
    with pytest.raises(DescriptionError) as err:
        load_metrics(path)
    _one_line_refusal(err.value, path)


def test_a_baseline_as_tiltload_writes_it_reads_back_its_samples(tmp_path):
    t = np.arange(5) * 0.1
    header = {k: v for k, v in good_header().items() if k != "format"}
    path = signal_baseline.write(tmp_path / "b.parquet", {"plant.x": (t, t**2), "plant.z": (t, -t)}, header)
    read, signals = signal_baseline.read(path)
    assert read["units"] == {"plant.x": "m"} and list(signals) == ["plant.x", "plant.z"]
    np.testing.assert_array_equal(signals["plant.x"][1], t**2)
    np.testing.assert_array_equal(signals["plant.z"][0], t)


def test_a_key_with_a_newline_is_named_on_the_one_line(tmp_path):
    """The case hypothesis found: a key "\\n" under "other" holding a 30-digit integer. The place is said with the
    newline escaped."""
    header = {**good_header(), "other": {"\n": 10**30}}
    path = write_parquet(tmp_path / "b.parquet", json.dumps(header).encode())
    with pytest.raises(DescriptionError) as caught:
        signal_baseline.read(path)
    _one_line_refusal(caught.value, path)
    assert str(caught.value).endswith("other.\\n: an integer of more than 18 digits")
