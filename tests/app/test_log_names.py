"""Every option of `tiltload run` either changes the default log name or is listed here with why it changes no run:
a new option must say which (the README's promise: a run with other options gets a log of its own)."""

from __future__ import annotations

import argparse

import pytest
from tiltload.master.app.case.log_name import default_log_name
from tiltload.master.app.case.options import resolve_loop
from tiltload.master.app.cli import parser
from tiltload.master.app.loop.thesis import default_stop

# options that change no metric and no logged value, with why
SAME_RUN = {
    "help": "prints the help",
    "allow_infeasible": "lets a run start that would be refused; the run is the same",
    "max_tilt": "the feasibility check's limit: refuses a run or not, changes none",
    "allow_external_fmus": "lets a system file's FMUs lie elsewhere; the system is the same",
    "allow_unknown_inputs": "accepts a controller with extra inputs; the run is the same",
    "fmus": "where tiltload builds its FMUs: the same FMUs in any folder (stale ones are rebuilt)",
    "out": "the folder the log goes to (its name is the folder's own)",
    "name": "names the log itself",
    "trust_fmus": "where an FMU runs (this process or its own): the same values (tests/engine isolation tests)",
    "step_timeout": "a watchdog: stops a hung FMU, changes no value of a run that completes",
    "token_file": "the remote server's secret",
    "no_plots": "no figures; the log is the same",
    "no_log": "no log at all",
    "quiet": "no progress bar",
    "report": "an HTML report beside the log; the run is the same",
    "expect_fmu": "refuses an FMU that is not the build named (a replay pinned by digest); the run it allows is the same",
    "profile": "times the steps and ticks (tests/engine/test_profile.py); the values are the same",
}
# an option -> (the command line without it, the command line with it): the two must be named apart
CHANGES = {
    "vehicle": ([], ["--vehicle", "uav"]),
    "scenario": ([], ["--scenario", "lkf"]),
    "trajectory": ([], ["--trajectory", "2"]),
    "wind": ([], ["--wind", "docs/examples/gusty_wind.yaml"]),
    "controller": ([], ["--controller", "dlqr"]),
    "seed": ([], ["--seed", "2"]),
    "stop_time": ([], ["--stop-time", "10"]),
    "delay": ([], ["--delay"]),
    "no_gusts": ([], ["--no-gusts"]),
    "faults": ([], ["--faults", "docs/faults/gps_dropout.json"]),
    "set": ([], ["--set", "plant.m_L=0.2"]),
    "system": ([], ["--system", "docs/loop.ssp"]),
    "step": (["--system", "standard.ssp"], ["--system", "standard.ssp", "--step", "0.05"]),
    "start_time": (["--system", "standard.ssp"], ["--system", "standard.ssp", "--start-time", "1"]),
    "input_file": (["--system", "docs/loop.ssp"], ["--system", "docs/loop.ssp", "--input-file", "plant=gusts.csv"]),
    "fmi": ([], ["--fmi", "3"]),
    "clocks": (["--fmi", "3"], ["--fmi", "3", "--clocks"]),
    "remote": ([], ["--remote", "controller=127.0.0.1:7390"]),
    "schedule": ([], ["--schedule", "jacobi"]),
    "log_every": ([], ["--log-every", "5"]),
    "snapshot_at": ([], ["--snapshot-at", "5", "snap.json"]),
    "from_snapshot": None,  # named by the snapshot's run + _from<T>s: test_the_resumed_run_is_named_apart
    "realtime": ([], ["--realtime"]),
    "max_overruns": (["--realtime"], ["--realtime", "--max-overruns", "3"]),
    "requirements": ([], ["--requirements", "docs/requirements/thesis.yaml"]),
    "stop_on_violation": (["--requirements", "docs/requirements/thesis.yaml"],
                          ["--requirements", "docs/requirements/thesis.yaml", "--stop-on-violation"]),
}


def _run_parser() -> argparse.ArgumentParser:
    sub = next(a for a in parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices["run"]


def _name(argv: list[str]) -> str:
    args = _run_parser().parse_args(argv)
    opts = resolve_loop(args)
    natural = 40.0 if opts.system is not None else default_stop(opts.reference or opts.trajectory)
    return default_log_name(args, opts, natural)


def test_every_option_of_run_is_classified():
    dests = {a.dest for a in _run_parser()._actions if a.option_strings}
    assert dests - set(SAME_RUN) - set(CHANGES) == set(), "options of `tiltload run` neither naming the log nor listed as the same run"
    assert (set(SAME_RUN) | set(CHANGES)) - dests == set(), "listed options `tiltload run` no longer has"


@pytest.mark.parametrize("option", [k for k, v in CHANGES.items() if v is not None])
def test_an_option_that_changes_the_run_changes_the_log_name(option):
    without, with_it = CHANGES[option]
    assert _name(without) != _name(with_it)


def test_the_names_of_all_the_changes_differ_from_one_another():
    names = [_name(v[1]) for v in CHANGES.values() if v is not None]
    assert len(set(names)) == len(names), names


def test_the_resumed_run_is_named_apart():
    args = _run_parser().parse_args([])
    opts = resolve_loop(args)
    assert default_log_name(args, opts, 40.0, resumed_at=12.0) == "zse_traj1_mixed_seed1_from12s"
    assert default_log_name(args, opts, 40.0) == "zse_traj1_mixed_seed1"  # the default case keeps its README name
