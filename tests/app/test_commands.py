"""The command line as a user meets it: a version, help on every positional argument, campaign-report as its own
command (the older form still works and says so), one default controller, a progress line that writes carriage
returns only to a terminal and says how long is left, a rebuild that says why."""

from __future__ import annotations

import argparse
import io
import json
import zipfile
from importlib import metadata
from types import SimpleNamespace

import pytest
from tiltload.master.app.cli import main, parser


def _subparsers(p: argparse.ArgumentParser, path=("tiltload",)):
    """Every (command path, parser) under p, nested subcommands included."""
    yield path, p
    for action in p._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _subparsers(sub, (*path, name))


def test_every_positional_argument_of_every_command_has_help():
    missing = []
    commands = list(_subparsers(parser()))
    assert len(commands) > 12  # the walk reached the subcommands
    for path, p in commands:
        for action in p._actions:
            if not action.option_strings and not isinstance(action, argparse._SubParsersAction):
                if not action.help or action.help == argparse.SUPPRESS:
                    missing.append(f"{' '.join(path)} {action.dest}")
    assert not missing, missing


def test_version_is_the_installed_package_s(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"tiltload {metadata.version('tiltload')}"


def test_campaign_report_is_a_command_and_the_older_form_says_what_replaced_it(tmp_path, capsys):
    missing = str(tmp_path / "none.parquet")
    assert main(["campaign-report", missing]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no such file" in err[0]
    assert main(["campaign", "report", missing]) == 2  # the same report, reached the old way: still one line
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no such file" in err[0]
    assert err[0].endswith("(note: `tiltload campaign report RESULTS` is now `tiltload campaign-report RESULTS`)")


def test_campaign_refuses_the_report_options_when_it_runs_a_spec(tmp_path, capsys):
    assert main(["campaign", str(tmp_path / "spec.toml"), "--x", "load_mass"]) == 2
    assert "campaign-report" in capsys.readouterr().err


def test_design_and_run_default_to_the_same_controller_for_each_vehicle():
    from tiltload.master.app.case.options import resolve_loop
    from tiltload.master.app.loop.thesis import LOOPS

    run_help = {a.dest: a for a in _find(parser(), "run")._actions}
    design = _find(parser(), "design")
    assert {a.dest: a for a in design._actions}["controller"].default is None  # resolved per vehicle, as run does
    for vehicle in ("load", "uav"):
        args = parser().parse_args(["run", "--vehicle", vehicle])
        assert resolve_loop(args).controller == LOOPS[vehicle].default_controller
    assert "mixed" in run_help["controller"].help and "mixed" in {a.dest: a for a in design._actions}["controller"].help


def _find(p, name):
    return next(sub for path, sub in _subparsers(p) if path[-1] == name)


class Stream(io.StringIO):
    def __init__(self, tty: bool):
        super().__init__()
        self.tty = tty

    def isatty(self):
        return self.tty


class FakeExecution:
    resumed_at = None
    system = SimpleNamespace(start_time=0.0)  # a run from t = 0 (the bar counts from the system's start time)


def _progress(tty: bool, elapsed_per_tick: float, ticks, stop=10.0, every=0.0, start=0.0):
    from tiltload.master.engine import observers

    stream = Stream(tty)
    p = observers.Progress(stop, stream, every=every, started=0.0)  # the run's clock: the mocked one's zero
    clock = iter([0.0, *(elapsed_per_tick * (i + 1) for i in range(len(ticks)))])
    real = observers.time.perf_counter
    observers.time.perf_counter = lambda: next(clock)
    try:
        execution = FakeExecution()
        execution.system = SimpleNamespace(start_time=start)
        p.start(execution)
        for t in ticks:
            p.on_tick(0, t)
        p.done(ticks[-1], elapsed_per_tick * len(ticks))  # the run's result's figures
    finally:
        observers.time.perf_counter = real
    return stream.getvalue()


def test_progress_to_a_file_is_plain_lines_with_the_time_left():
    text = _progress(False, 1.0, [1.0, 2.0, 5.0])  # 1 s of wall time per call: 1, 2, 5 s simulated of 10
    assert "\r" not in text
    lines = text.splitlines()
    assert len(lines) == 3
    # at t = 2 s after 2 s of wall time: 1x real time, 8 s simulated left -> 8 s; at t = 5 after 3 s: 5 s left -> 3 s
    assert lines[1].endswith("(1x real time, 8 s left)") and lines[2].endswith("(2x real time, 3 s left)")


def test_progress_after_a_later_start_counts_from_it():
    """A system that starts at 1000 s and stops at 1010 s: 2 s done of 10 is 20 %, not 99 %."""
    lines = _progress(False, 1.0, [1001.0, 1002.0], stop=1010.0, start=1000.0).splitlines()
    assert lines[-1].lstrip().startswith("20.0 %") and "(1x real time, 8 s left)" in lines[-1], lines


def test_progress_on_a_terminal_redraws_one_line_in_place():
    text = _progress(True, 60.0, [1.0, 2.0])  # a slow run: 60 s per simulated second
    assert text.count("\r") == 3 and text.endswith("\n") and text.count("\n") == 1  # two frames, then the last
    assert "8 min 00 s left" in text


def test_a_quiet_redirected_short_run_writes_nothing():
    assert _progress(False, 0.1, [1.0, 10.0], every=10.0) == ""


def _fake_fmu(path, record):
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("resources/build_info.json", json.dumps({"source_hash": "x", "inputs": record}))


def test_a_rebuild_names_what_changed(tmp_path):
    from tiltload.native_fmu.build import rebuild_reason

    old = {"files": {"plant_fmu/model.py": "aa", "native_fmu/c/tl_core.c": "bb"}, "platforms": ["linux64"],
           "compilers": {"linux64": "gcc 12"}, "flags": "-O2", "machine": "x86_64", "version": "0.1.0",
           "identity": ["casadi 3.6"], "fmi": 2}
    fmu = tmp_path / "A.fmu"
    _fake_fmu(fmu, old)
    assert rebuild_reason(fmu, old) is None
    wider = {**old, "platforms": ["linux64", "win64"], "compilers": {"linux64": "gcc 12", "win64": "mingw 12"}}
    assert rebuild_reason(fmu, wider).startswith("the platforms changed (linux64 -> linux64, win64")
    edited = {**old, "files": {**old["files"], "plant_fmu/model.py": "cc"}}
    assert rebuild_reason(fmu, edited) == "source changed: plant_fmu/model.py"
    assert rebuild_reason(fmu, {**old, "version": "0.2.0"}) == "tiltload's version changed (0.1.0 -> 0.2.0)"
    assert rebuild_reason(tmp_path / "none.fmu", old) == "not built yet"
    assert rebuild_reason(fmu, old, force=True) == "--force"


def test_the_build_record_names_the_recipe_s_own_files():
    from tiltload.native_fmu.build import inputs_record
    from tiltload.native_fmu.compile import choose
    from tiltload.plant_fmu.build import recipe

    r = recipe()
    record = inputs_record(r, choose()[0])
    assert any(name.startswith("plant_fmu/") for name in record["files"])
    assert "native_fmu/build.py" in record["files"]
    assert record["platforms"] == [t.folder for t in choose()[0]]
