"""One table of errors (master/app/errors.py) read by the command and the API: the same case refused by both faces gives
the same line and the same exit code (issue 61)."""

from __future__ import annotations

import pytest
import tiltload as tl
from tiltload.master.app.cli import main

SPEC = 'name = "bad"\n[base]\nscenario = "nowhere"\n[vary]\nseeds = [1]\n'


def _cli(argv, capsys) -> tuple[int, str]:
    try:
        code = main(argv)
    except SystemExit as done:  # the parser's own refusal
        code = done.code
    return code, capsys.readouterr().err.strip()


def test_a_refused_option_is_the_same_line_and_code_from_the_command_and_the_api(capsys):
    code, line = _cli(["run", "--stop-time", "-1"], capsys)
    with pytest.raises(tl.TiltloadError) as err:
        tl.Case(stop_time=-1)
    assert code == err.value.exit_code == 2
    assert line == err.value.cli_line and "\n" not in line


def test_a_bad_spec_is_the_same_line_and_code_from_the_command_and_the_api(tmp_path, capsys):
    spec = tmp_path / "bad.toml"
    spec.write_text(SPEC)
    code, line = _cli(["campaign", str(spec), "--out", str(tmp_path / "out")], capsys)
    with pytest.raises(tl.TiltloadError) as err:
        tl.campaign(spec, tl.CampaignOptions(out=tmp_path / "out"))
    assert code == err.value.exit_code == 2
    assert line == err.value.cli_line and "base.scenario" in line


def test_a_failed_build_is_exit_1_from_both_faces(monkeypatch, tmp_path, capsys):
    from tiltload.master.app.loop import fmus
    from tiltload.native_fmu.compile import BuildError

    def broken(*args, **kwargs):
        raise BuildError("cc: not found")

    monkeypatch.setattr(fmus, "build_all", broken)
    code, line = _cli(["run", "--scenario", "fsi", "--stop-time", "0.1", "--fmus", str(tmp_path / "f"), "--no-log"], capsys)
    with pytest.raises(tl.TiltloadError) as err:
        tl.run(scenario="fsi", stop_time=0.1, fmus=tmp_path / "f", no_log=True)
    assert code == err.value.exit_code == 1
    assert line == err.value.cli_line == "tiltload: error: building the FMUs failed: cc: not found"


def test_every_kind_of_the_table_has_a_documented_exit_code():
    from pathlib import Path

    from tiltload.master.app.errors import KINDS

    doc = (Path(__file__).resolve().parents[2] / "docs" / "exit_codes.md").read_text()
    for kind in KINDS:
        assert f"{kind.exit_code} " in doc or f"| {kind.exit_code} |" in doc
