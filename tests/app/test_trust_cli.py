"""Issue 37, the command line's side: token files checked before they are read, no abbreviated options, every wait
bounded where it is parsed, errors that keep their cause, campaigns that fail a case for itself and leave nothing in
$TMPDIR. Each test names the one line it expects."""

from __future__ import annotations

import ast
import os
import re
import resource
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from tiltload.master.app import cli
from tiltload.master.app.cli import main

RUN = ["run", "--stop-time", "0.2", "--quiet", "--no-log", "--no-plots"]


def tiltload(*argv: str, timeout: float = 120, env: dict | None = None) -> subprocess.CompletedProcess:
    """The command in a process of its own, its memory capped at 2 GB and its time bounded: what hung or ate memory
    before fails here instead of taking the machine."""
    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
    return subprocess.run([sys.executable, "-m", "tiltload.master.app.cli", *argv], capture_output=True, text=True,
                          timeout=timeout, preexec_fn=cap, env={**os.environ, **(env or {})})


def exit_code(argv: list[str]) -> int:
    """main's code, argparse's exit included."""
    try:
        return main(argv)
    except SystemExit as done:
        return done.code


def one_line(stderr: str) -> str:
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


# --- token files --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("kind", ["fifo", "zero", "folder", "large"])
@pytest.mark.parametrize("command", ["serve", "run"])
@pytest.mark.slow
def test_a_token_file_that_is_not_a_small_regular_file_is_refused_before_it_is_read(fmus, tmp_path, kind, command):
    if kind == "fifo":
        path = tmp_path / "fifo"
        os.mkfifo(path, 0o600)
    elif kind == "zero":
        path = Path("/dev/zero")
    elif kind == "folder":
        path = tmp_path / "folder"
        path.mkdir(mode=0o700)
    else:
        path = tmp_path / "large"
        path.write_bytes(b"x" * 5000)
        path.chmod(0o600)
    argv = (["serve", "--fmus", str(fmus), "--token-file", str(path)] if command == "serve" else
            [*RUN, "--fmus", str(fmus), "--remote", "controller=127.0.0.1:9", "--token-file", str(path)])
    done = tiltload(*argv, timeout=60)
    line = one_line(done.stderr)
    what = "holds 5000 bytes; a token file holds at most 4096" if kind == "large" else "is not a regular file"
    assert done.returncode == 2
    assert line == f"tiltload: error: token file {path} {what}"


def test_a_secret_given_to_an_abbreviation_is_neither_taken_nor_echoed(fmus, capsys):
    secret = "s3cr3t-VALUE-0123456789"
    for flag in ([f"--token={secret}"], ["--token", secret], ["--token-f", secret]):
        code = exit_code([*RUN, "--fmus", str(fmus), "--remote", "controller=127.0.0.1:9", *flag])
        err = capsys.readouterr().err
        assert code == 2 and secret not in err, err
        shown = flag[0].partition("=")[0]
        hidden = "" if "=" in flag[0] else " (and 1 value not shown)"
        assert one_line(err) == f"tiltload: error: unrecognized arguments: {shown}{hidden} (see: tiltload --help)"


def test_no_parser_of_the_project_takes_abbreviations():
    p = cli.parser()
    subparsers = next(a for a in p._actions if a.choices and isinstance(a.choices, dict))
    assert p.allow_abbrev is False
    assert {name: sub.allow_abbrev for name, sub in subparsers.choices.items()} == dict.fromkeys(subparsers.choices, False)
    root = Path(__file__).resolve().parents[2]
    found = 0
    for source in [*root.glob("master/**/*.py"), *root.glob("benchmarks/*.py"), *root.glob("*_fmu/**/*.py")]:
        for node in ast.walk(ast.parse(source.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) == "ArgumentParser":
                found += 1
                given = {k.arg: k.value for k in node.keywords}
                assert "allow_abbrev" in given and given["allow_abbrev"].value is False, f"{source}:{node.lineno}"
    assert found >= 10  # the worker, the server and the benchmarks


# --- bounded waits ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("argv, line", [
    (["serve", "--token-file", "t", "--handshake-timeout", "1e12"],
     "tiltload serve: error: argument --handshake-timeout: must be a positive time in s, at most 3600, got 1e12 "
     "(see: tiltload serve --help)"),
    (["serve", "--token-file", "t", "--idle-timeout", "1e12"],
     "tiltload serve: error: argument --idle-timeout: must be a positive time in s, at most 86400, got 1e12 "
     "(see: tiltload serve --help)"),
    ([*RUN, "--step-timeout", "1e12"],
     "tiltload run: error: argument --step-timeout: must be a positive time in s, at most 86400, got 1e12 "
     "(see: tiltload run --help)"),
    (["campaign", "spec.toml", "--worker-timeout", "1e12"],
     "tiltload campaign: error: argument --worker-timeout: must be a positive time in s, at most 86400, got 1e12 "
     "(see: tiltload campaign --help)"),
    (["campaign", "spec.toml", "--connect-timeout", "1e5"],
     "tiltload campaign: error: argument --connect-timeout: must be a positive time in s, at most 3600, got 1e5 "
     "(see: tiltload campaign --help)"),
    ([*RUN, "--realtime", "1e-12"],
     "tiltload run: error: argument --realtime: must be from 0.001 to 1000, got 1e-12 (see: tiltload run --help)"),
    (["design", "--Tc", "1e300"],
     "tiltload design: error: argument --Tc: must be a positive period in s, at most 1, got 1e300 "
     "(see: tiltload design --help)"),
])
@pytest.mark.slow
def test_every_wait_is_bounded_where_it_is_parsed(argv, line):
    done = tiltload(*argv, timeout=60)  # before: serve listened for ever, run and design went on
    assert (done.returncode, one_line(done.stderr)) == (2, line)


@pytest.mark.parametrize("command, option, bound", [("serve", "--handshake-timeout", "at most 3600 s"),
                                                    ("serve", "--idle-timeout", "at most 86400 s"),
                                                    ("run", "--step-timeout", "at most 86400 s"),
                                                    ("campaign", "--worker-timeout", "at most 86400"),
                                                    ("campaign", "--connect-timeout", "at most 3600"),
                                                    ("run", "--realtime", "from 0.001 to 1000")])
def test_each_bound_is_in_its_help(command, option, bound, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    helped = text[text.index(option, text.index("options:")):]  # past the usage lines
    assert bound in helped[:400], helped[:400]


# --- errors keep their cause --------------------------------------------------------------------------------------

def test_an_observer_failing_after_the_plant_failed_does_not_replace_its_message(fmus, capsys):
    """A steady wind of 1e300 m/s: the plant refuses its infinite disturbance at the first tick; the metrics observer
    then trips on that call's empty batch, and used to say only "index 0 is out of bounds"."""
    code = main([*RUN, "--fmus", str(fmus), "--set", "scenario.steady_wind_x=1e300"])
    assert code == 1  # the run failed (a run's failure is exit 1; bad options are 2)
    assert one_line(capsys.readouterr().err) == ("tiltload: error: plant: setReal from scenario at t=0 s failed (error): "
                                                 "non-finite input d_x = inf at t=0 s; value refused; no log (--no-log)")


def test_an_fmi3_controller_without_an_instantiation_token_is_one_line(fmus, fmi3_fmus, tmp_path, capsys):
    bad = tmp_path / "notoken.fmu"
    with zipfile.ZipFile(fmi3_fmus["TiltloadController"]) as z, zipfile.ZipFile(bad, "w") as out:
        for item in z.infolist():
            data = z.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb'\s+instantiationToken="[^"]*"', b"", data)
            out.writestr(item, data)
    assert main([*RUN, "--fmus", str(fmus), "--controller", str(bad)]) == 2
    assert one_line(capsys.readouterr().err) == (f"tiltload: error: controller: {bad} declares no instantiationToken in its "
                                                 "modelDescription.xml (FMI 3.0 requires one)")


# --- campaigns ----------------------------------------------------------------------------------------------------

def test_a_binary_spec_is_one_line(tmp_path, capsys):
    spec = tmp_path / "spec.toml"
    spec.write_bytes(bytes(range(256)))
    code = exit_code(["campaign", str(spec), "--out", str(tmp_path / "out")])
    assert (code, one_line(capsys.readouterr().err)) == (
        2, f"tiltload: error: {spec}: not a UTF-8 text file (byte 128)")


def test_a_spec_that_is_not_a_file_is_one_line(tmp_path, capsys):
    """A folder (or a FIFO) named like a spec: refused before it is opened (root reads any file, so no chmod case)."""
    spec = tmp_path / "spec.toml"
    spec.mkdir()
    code = exit_code(["campaign", str(spec), "--out", str(tmp_path / "out")])
    assert (code, one_line(capsys.readouterr().err)) == (2, f"tiltload: error: spec {spec}: a folder, not a regular file")


@pytest.mark.slow
def test_a_controller_that_is_not_an_fmu_is_refused_before_a_cluster_and_leaves_nothing_in_tmpdir(fmus, tmp_path,
                                                                                                  monkeypatch):
    """A campaign whose controller is no FMU is the spec's error, said in one line before any cluster starts (issue 62:
    it ran and failed each of its runs), and nothing is left in TMPDIR."""
    import tempfile

    from tiltload.master.app.campaign import runner
    from tiltload.master.app.case.spec_file import SpecError

    scratch = tmp_path / "tmpdir"
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    (tmp_path / "text.fmu").write_text("not an FMU")
    spec = tmp_path / "spec.toml"
    spec.write_text('name = "c"\n[base]\nstop_time = 0.2\ncontrollers = ["dlqr", "text.fmu"]\n[vary]\nseeds = [1]\n')
    with pytest.raises(SpecError, match=r"base\.controllers: controller: .*text\.fmu is not an FMU \(not a zip archive\)"):
        runner.run(spec, tmp_path / "out", workers=1, fmus=fmus, progress=lambda _: None)
    assert not (tmp_path / "out" / "parts").exists() or not list((tmp_path / "out" / "parts").iterdir())
    assert not list(scratch.iterdir())  # no dask-scratch-space/{global,purge}.lock
