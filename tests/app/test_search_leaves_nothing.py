"""A search and a campaign leave nothing in $TMPDIR (Dask's scratch space of every server, its lock files, is in a
folder of the command's own), and what they refuse they refuse before any cluster starts (issue 62)."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time

import pytest
from support.isolated_case import GRACE_S, group_members
from test_bad_input import CAMPAIGN_SPEC, FALSIFY_SPEC


@pytest.mark.slow
def test_falsify_with_a_private_empty_tmpdir_leaves_it_empty(fmus, tmp_path):
    """A real search (two simulations on a local cluster of one worker), the command in a process and session of its
    own (not a fork of this one, whose earlier tests may hold Dask's threads), TMPDIR a fresh empty folder: exit 0 and
    its results, and the folder is empty again, no process of its session alive."""
    spec = tmp_path / "f.toml"
    spec.write_text(FALSIFY_SPEC)
    out, scratch = tmp_path / "out", tmp_path / "tmpdir"
    scratch.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "tiltload.master.app.cli", "falsify", str(spec), "--out", str(out),
                             "--workers", "1", "--fmus", str(fmus)], env={**os.environ, "TMPDIR": str(scratch)},
                            cwd=tmp_path, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        _, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err[-2000:]
        assert (out / "falsification.parquet").is_file()
        assert sorted(p.name for p in scratch.iterdir()) == []  # dask-scratch-space/{global,purge}.lock before issue 62
        deadline = time.monotonic() + GRACE_S  # a resource tracker ends when its pipe closes
        while group_members(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert group_members(proc.pid) == []
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def _no_cluster(monkeypatch) -> None:
    from tiltload.master.app.batch import cluster

    def refuse(*args, **kwargs):
        raise AssertionError("a cluster was started")
    monkeypatch.setattr(cluster, "local_cluster", refuse)


@pytest.mark.parametrize("kind", ["a text file", "a zip that is no FMU"])
def test_a_campaign_controller_that_is_not_an_fmu_is_refused_before_a_cluster(fmus, tmp_path, monkeypatch, capsys, kind):
    import zipfile

    from tiltload.master.app.cli import main

    _no_cluster(monkeypatch)
    controller = tmp_path / ("notes.txt" if kind == "a text file" else "c.fmu")
    if kind == "a text file":
        controller.write_text("a controller\n")
    else:
        with zipfile.ZipFile(controller, "w") as z:
            z.writestr("readme.txt", "no model description")
    spec = tmp_path / "c.toml"
    spec.write_text(CAMPAIGN_SPEC.replace('controllers = ["dlqr"]', f"controllers = [{json.dumps(controller.name)}]"))
    assert main(["campaign", str(spec), "--out", str(tmp_path / "out"), "--workers", "1", "--fmus", str(fmus)]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("tiltload")]
    assert len(err) == 1 and "base.controllers" in err[0] and controller.name in err[0], err


@pytest.mark.parametrize("command", ["campaign", "falsify"])
@pytest.mark.parametrize("kind", ["a file", "a FIFO", "a dangling link"])
def test_something_not_a_folder_where_parts_goes_is_one_line_before_a_cluster(fmus, tmp_path, monkeypatch, capsys,
                                                                              command, kind):
    from tiltload.master.app.cli import main

    _no_cluster(monkeypatch)
    spec = tmp_path / "s.toml"
    spec.write_text(CAMPAIGN_SPEC if command == "campaign" else FALSIFY_SPEC)
    out = tmp_path / "out"
    out.mkdir()
    parts = out / "parts"
    {"a file": lambda: parts.write_text("x"), "a FIFO": lambda: os.mkfifo(parts),
     "a dangling link": lambda: parts.symlink_to(tmp_path / "nowhere")}[kind]()
    assert main([command, str(spec), "--out", str(out), "--workers", "1", "--fmus", str(fmus)]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("tiltload")]
    assert len(err) == 1 and f"{parts} is not a folder" in err[0], err
    assert os.path.lexists(parts) and not parts.is_dir()  # left as it was
