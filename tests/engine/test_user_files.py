"""The one input layer (engine/user_files.py): every file a user hands in is bounded before it is read, and every
refusal is one line naming the file and the problem."""

from __future__ import annotations

import json
import os

import pytest
from tiltload.master.engine import user_files as uf
from tiltload.master.engine.user_files import UserFileError


def _refused(read, path, *args) -> str:
    with pytest.raises(UserFileError) as err:
        read(path, *args)
    message = str(err.value)
    assert "\n" not in message and message.startswith(str(path)), message
    return message


def test_the_size_is_checked_before_the_file_is_read(tmp_path):
    path = tmp_path / "big.json"
    path.write_text("[" + "0," * 600 + "0]")
    assert _refused(uf.read_json, path, 1000).endswith(f"{path.stat().st_size} bytes, more than the 1000 a file given to "
                                                       "tiltload may have")
    assert uf.read_json(path, 2000) == [0] * 601


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs")
def test_only_regular_files_are_read(tmp_path):
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)  # opening it would block until a writer came
    assert _refused(uf.read_yaml, fifo).endswith("not a regular file")
    assert _refused(uf.read_json, tmp_path).endswith("not a regular file")
    assert _refused(uf.read_json, tmp_path / "missing.json").endswith("no such file")


@pytest.mark.parametrize("data, needle", [
    (b"\xff\xfe{}", "not a UTF-8 text file (byte 0)"),
    (b'{"a": 1}\x00', "not a text file (it holds a NUL character)"),
])
def test_text_is_utf8_without_nul(tmp_path, data, needle):
    path = tmp_path / "f.json"
    path.write_bytes(data)
    assert _refused(uf.read_json, path).endswith(needle)


@pytest.mark.parametrize("text, needle", [
    ('{"a": [1, 2, %s]}' % ("9" * 19), "a.2: an integer of 19 digits (at most 18)"),
    ('{"a": {"b": 1e309}}', "a.b: 1e309 is beyond a double's range"),
    ('{"a": -Infinity}', "a: -Infinity is not a finite number"),
    ('[0, NaN]', "1: NaN is not a finite number"),
    ("[" * 33 + "]" * 33, "nested deeper than 32 levels"),
    ("[" * 100_000 + "]" * 100_000, "nested deeper than 32 levels"),
    ('{"a": ', "not valid JSON: Expecting value: line 1 column 7 (char 6)"),
])
def test_json_numbers_and_nesting_are_checked_as_parsed(tmp_path, text, needle):
    path = tmp_path / "f.json"
    path.write_text(text)
    assert _refused(uf.read_json, path).endswith(needle)


def test_the_largest_accepted_values_pass(tmp_path):
    path = tmp_path / "ok.json"
    data = {"a": [10**18 - 1, -(10**18 - 1), 1.7e308, -5e-324], "b": {"c": [[[]]]}}
    path.write_text(json.dumps(data))
    assert uf.read_json(path) == data


@pytest.mark.parametrize("text, needle", [
    ("a: &x [1, 2]\nb: *x\n", "line 2: a YAML alias (*x): aliases are not accepted (write the value out)"),
    ("a: .nan\n", "a: nan is not a finite number"),
    ("a: [1, .inf]\n", "a.1: inf is not a finite number"),
    (f"a: {'9' * 400}\n", "a: an integer of more than 18 digits"),
    ("? [1, 2]\n: 3\n", "not valid YAML"),
    ("1: x\n", "the key '1' is not text"),
    ("a: [\n", "not valid YAML at line 2, column 1: expected the node content"),
])
def test_yaml_refuses_aliases_and_what_json_refuses(tmp_path, text, needle):
    path = tmp_path / "f.yaml"
    path.write_text(text)
    assert needle in _refused(uf.read_yaml, path)


def test_yaml_anchors_without_aliases_are_harmless(tmp_path):
    path = tmp_path / "f.yaml"
    path.write_text("a: &x [1, 2]\nb: 3\n")
    assert uf.read_yaml(path) == {"a": [1, 2], "b": 3}


def test_toml_values_are_checked_too(tmp_path):
    path = tmp_path / "f.toml"
    path.write_text("a = nan\n")
    assert _refused(uf.read_toml, path).endswith("a: nan is not a finite number")


def test_csv_lines_are_bounded_and_comments_skipped(tmp_path):
    path = tmp_path / "f.csv"
    path.write_text("# a comment\nt,x\n\n0,1\n" + "1," + "2" * 5000 + "\n")
    assert _refused(uf.read_csv, path).endswith("line 5: 5002 characters, more than 4096")
    path.write_text("# a comment\nt,x\n\n0,\"1\"\n")
    assert uf.read_csv(path) == [(2, ["t", "x"]), (4, ["0", "1"])]
