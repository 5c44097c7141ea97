"""A snapshot is data (issue 37): a file that is at once a snapshot and an FMU naming itself as the controller is
never loaded, in a continued run or in a campaign's branches; a snapshot's manifest and options are checked before
use; a zip bomb inside one is refused unread; a continued run must stop after the snapshot's time."""

from __future__ import annotations

import json
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from tiltload.master.app.cli import main

EVIL_C = r"""
#include <stdio.h>
__attribute__((constructor)) static void mark(void) {
    FILE *f = fopen(MARKER, "w");
    if (f) { fputs("the snapshot's library ran\n", f); fclose(f); }
}
"""


def _one_error(capfd, progress: bool = False) -> str:
    """The one error line on stderr (progress: after a campaign's progress lines, which go there too)."""
    err = capfd.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    errors = [ln for ln in lines if "error" in ln]
    assert "Traceback" not in err and len(errors) == 1 and (progress or len(lines) == 1), err
    assert lines[-1] == errors[0], err
    return errors[0]


def _rewrite(src: Path, dest: Path, edit_manifest, extra: dict[str, bytes] | None = None) -> Path:
    """src's members, its manifest edited, and extra members added."""
    with zipfile.ZipFile(src) as z, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as out:
        for item in z.infolist():
            data = z.read(item.filename)
            if item.filename == "manifest.json":
                data = json.dumps(edit_manifest(json.loads(data))).encode()
            out.writestr(item.filename, data)
        for name, data in (extra or {}).items():
            out.writestr(name, data)
    return dest


@pytest.fixture(scope="module")
def polyglot(fmus, tmp_path_factory):
    """(folder, the polyglot snapshot's name, the marker its library's constructor would write, the controller copy).
    The snapshot is a real one of a run with a user's controller FMU (a copy of ours), its options edited so the
    controller is the snapshot file itself (a relative path), which also holds that controller's model description
    and, for its model identifier, a shared library whose constructor writes the marker."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler")
    folder = tmp_path_factory.mktemp("polyglot")
    controller = folder / "mine.fmu"
    shutil.copy(fmus / "TiltloadController.fmu", controller)
    taken = folder / "taken.snapshot"
    assert main(["run", "--controller", str(controller), "--stop-time", "1", "--snapshot-at", "0.5", str(taken),
                 "--fmus", str(fmus), "--no-log", "--quiet", "--no-plots"]) == 0
    marker = folder / "MARKER"
    source = folder / "evil.c"
    source.write_text(EVIL_C)
    library = folder / "evil.so"
    subprocess.run(["cc", "-shared", "-fPIC", f'-DMARKER="{marker}"', "-o", str(library), str(source)], check=True)
    extra = {}
    with zipfile.ZipFile(controller) as z:
        extra["modelDescription.xml"] = z.read("modelDescription.xml")
        for name in z.namelist():
            if name.startswith("binaries/") and name.endswith((".so", ".dylib", ".dll")):
                extra[name] = library.read_bytes()

    def itself(m):
        m["application"]["options"]["controller"] = "poly.snapshot"
        m["application"]["options"]["controller_fmu"] = "poly.snapshot"
        return m
    _rewrite(taken, folder / "poly.snapshot", itself, extra)
    return folder, "poly.snapshot", marker, controller


def test_the_polyglot_is_an_fmu_whose_library_writes_the_marker(polyglot, tmp_path):
    """The test's own premise: loading the polyglot's library does write the marker (so its absence below means
    nothing loaded it)."""
    import ctypes

    folder, name, marker, _ = polyglot
    with zipfile.ZipFile(folder / name) as z:
        so = next(n for n in z.namelist() if n.startswith("binaries/") and n.endswith(".so"))
        z.extract(so, tmp_path)
    probe = tmp_path / "probe"
    ctypes.CDLL(str(tmp_path / so))
    assert marker.exists()
    marker.rename(probe)


def test_a_continued_run_never_loads_an_fmu_the_snapshot_locates(polyglot, fmus, capfd, monkeypatch):
    folder, name, marker, _ = polyglot
    monkeypatch.chdir(folder)  # where the snapshot's relative path points
    marker.unlink(missing_ok=True)
    code = main(["run", "--from-snapshot", name, "--fmus", str(fmus), "--no-log", "--quiet", "--no-plots"])
    line = _one_error(capfd)
    assert code == 2 and not marker.exists()
    assert line == (f"tiltload: error: --from-snapshot {name}: it was taken with the controller file {name}: name it again "
                    "with --controller PATH (a snapshot never says where files are; its digest is checked)")
    # named on the command line, it is checked against the digest the snapshot recorded (its own, which no file has)
    code = main(["run", "--from-snapshot", name, "--controller", name, "--fmus", str(fmus), "--no-log", "--quiet"])
    line = _one_error(capfd)
    assert code == 2 and not marker.exists()
    assert line.startswith("tiltload: error: controller: its FMU is not the file the snapshot was taken with (SHA-256 ")
    assert line.endswith("here): nothing was loaded")


def test_a_campaign_never_loads_an_fmu_the_snapshot_locates(polyglot, fmus, capfd, monkeypatch):
    folder, name, marker, controller = polyglot
    monkeypatch.chdir(folder)
    marker.unlink(missing_ok=True)
    spec = folder / "branches.toml"
    spec.write_text(f'name = "b"\n[base]\nsnapshot = "{name}"\nstop_time = 1.0\n[vary]\nseeds = [1, 2]\n')
    code = main(["campaign", str(spec), "--out", str(folder / "out"), "--fmus", str(fmus), "--workers", "1"])
    line = _one_error(capfd, progress=True)
    assert code == 2 and not marker.exists()
    assert line == (f"tiltload: error: {spec}: base.controllers: {folder / name} was taken with the controller FMU {name}: "
                    "name that one file in base.controllers (its digest is checked)")
    spec.write_text(spec.read_text().replace("stop_time", f'controllers = ["{name}"]\nstop_time'))
    code = main(["campaign", str(spec), "--out", str(folder / "out"), "--fmus", str(fmus), "--workers", "1"])
    line = _one_error(capfd, progress=True)
    assert code == 2 and not marker.exists()
    assert "base.snapshot: controller: its FMU is not the file the snapshot was taken with" in line


def test_nothing_is_created_where_a_snapshot_says(polyglot, fmus, tmp_path, capfd, monkeypatch):
    """The snapshot's own FMU folder is gone: the run uses the command line's (default fmus/), and builds nothing where
    the snapshot said."""
    folder, _, _, controller = polyglot
    monkeypatch.chdir(tmp_path)
    elsewhere = tmp_path / "gone" / "fmus"

    def moved(m):
        m["application"]["options"]["fmus"] = str(elsewhere)
        return m
    snap = _rewrite(folder / "taken.snapshot", tmp_path / "moved.snapshot", moved)
    assert main(["run", "--from-snapshot", str(snap), "--controller", str(controller), "--fmus", str(fmus), "--no-log",
                 "--quiet", "--no-plots"]) == 0
    assert not (tmp_path / "gone").exists()


@pytest.fixture(scope="module")
def taken(fmus, tmp_path_factory) -> Path:
    """A snapshot at 0.5 s of a 1 s ZSE run of the loop."""
    path = tmp_path_factory.mktemp("taken") / "at.snapshot"
    assert main(["run", "--stop-time", "1", "--snapshot-at", "0.5", str(path), "--fmus", str(fmus), "--no-log", "--quiet",
                 "--no-plots"]) == 0
    return path


def _continue(snap: Path, fmus: Path, *extra: str) -> int:
    return main(["run", "--from-snapshot", str(snap), "--fmus", str(fmus), "--no-log", "--quiet", "--no-plots", *extra])


def _edit(path, key, value):
    def edit(m):
        target = m
        for k in key[:-1]:
            target = target[k]
        if value is KeyError:
            del target[key[-1]]
        else:
            target[key[-1]] = value
        return m
    return edit


@pytest.mark.parametrize("key, value, message", [
    (["values"], [], "its manifest is not a snapshot's: values: [] is not of type 'object'"),
    (["ticks_done"], -3, "its manifest is not a snapshot's: ticks_done: -3 is less than the minimum of 0"),
    (["fingerprint", "instances"], {"plant": 1}, "its manifest is not a snapshot's: fingerprint.instances: {'plant': 1} is not "
                                                 "of type 'array'"),
    (["bogus"], 1, "its manifest is not a snapshot's: (top level): Additional properties are not allowed ('bogus' was "
                   "unexpected)"),
    (["application", "options", "scenario"], KeyError, "its loop options are not a run's: options.(all): 'scenario' is a "
                                                       "required property"),
    (["application", "options", "colour"], "red", "its loop options are not a run's: options.(all): Additional properties are "
                                                  "not allowed ('colour' was unexpected)"),
    (["application", "options", "seed"], "1", "its loop options are not a run's: options.seed: '1' is not of type 'integer'"),
])
def test_a_manifest_of_the_wrong_shape_is_one_line(taken, fmus, tmp_path, capfd, key, value, message):
    bad = _rewrite(taken, tmp_path / "bad.snapshot", _edit(taken, key, value))
    code = _continue(bad, fmus)
    assert (code, _one_error(capfd)) == (2, f"tiltload: error: {bad}: {message}")


def test_a_snapshot_edited_to_another_scenario_is_refused(taken, fmus, tmp_path, capfd):
    bad = _rewrite(taken, tmp_path / "lkf.snapshot", _edit(taken, ["application", "options", "scenario"], "lkf"))
    assert _continue(bad, fmus) == 2
    assert _one_error(capfd) == ("tiltload: error: controller: its parameters differ from those the snapshot was taken with "
                                 "(another scenario, trajectory, seed, wind or --set: the snapshot's options were edited, or "
                                 "are of another run)")


@pytest.mark.parametrize("stop", ["0.5", "0.3"])
def test_a_continued_run_must_stop_after_the_snapshot(taken, fmus, capfd, stop):
    assert _continue(taken, fmus, "--stop-time", stop) == 2
    assert _one_error(capfd) == (f"tiltload: error: --stop-time {stop}: a continued run must stop after the snapshot's "
                                 "time (0.504 s)")


@pytest.mark.slow
def test_a_zip_bomb_in_a_snapshot_is_refused_unread(taken, fmus, tmp_path, capfd):
    """300 MB of zeros (300 kB on disk) as the plant's state: refused by its declared size, never decompressed."""
    bomb = tmp_path / "bomb.snapshot"
    with zipfile.ZipFile(taken) as z, zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as out:
        for item in z.infolist():
            if item.filename != "fmu/plant.state":
                out.writestr(item.filename, z.read(item.filename))
        with out.open("fmu/plant.state", "w", force_zip64=True) as f:
            zeros = bytes(1 << 20)
            for _ in range(300):
                f.write(zeros)
    assert bomb.stat().st_size < 2 << 20
    assert _continue(bomb, fmus) == 2
    assert _one_error(capfd) == (f"tiltload: error: {bomb}: fmu/plant.state declares {300 << 20} bytes, more than a "
                                 f"snapshot holds ({256 << 20}): refused unread")
