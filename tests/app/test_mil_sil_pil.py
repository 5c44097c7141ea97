"""MIL / SIL / PIL of the thesis's controller back to back (docs/mil_sil_pil.md): the numpy reference in a Python
process and the FMU's aarch64 binary on tl_serve under qemu-user, each the remote controller of a run, against the C
FMU in process, within the documented tolerances; a gain 1 % off caught where numpy finds it first; tl_serve's
handshake refusing a wrong token; the stages refused in one line where they cannot run."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import tiltload as tl
from tiltload.master.app.cli import main
from tiltload.master.app.regression.back_to_back import SIGNALS
from tiltload.master.engine.log.reader import read_columns

TOLERANCE = {"abs": 1e-6, "rel": 1e-6}  # docs/mil_sil_pil.md: the same controller, every signal
CASE = {"scenario": "lkf", "trajectory": 1, "controller": "dlqr"}
STOP = 1.2
needs_qemu = pytest.mark.skipif(not (shutil.which("qemu-aarch64") and shutil.which("aarch64-linux-gnu-gcc")
                                     and Path("/usr/aarch64-linux-gnu").is_dir()),
                                reason="PIL needs qemu-aarch64, aarch64-linux-gnu-gcc and the arm64 sysroot")


def _signals(log: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    columns, _ = read_columns(log)
    return {n: (columns["/" + n.split(".")[0]][0], columns["/" + n.split(".")[0]][1][n.split(".")[1]]) for n in SIGNALS}


def _first_outside(reference: Path, candidate: Path) -> tuple[float | None, float]:
    """numpy on the two logs (one tick grid): the first time any signal leaves |c - r| <= max(abs, rel |r|), and the
    largest |c - r| of all."""
    ref, cand = _signals(reference), _signals(candidate)
    first, largest = [], 0.0
    for name in SIGNALS:
        (t, r), (tc, c) = ref[name], cand[name]
        assert np.array_equal(t, tc)
        out = np.abs(c - r) > np.maximum(TOLERANCE["abs"], TOLERANCE["rel"] * np.abs(r))
        first += [t[np.argmax(out)]] if out.any() else []
        largest = max(largest, float(np.abs(c - r).max()))
    return (min(first) if first else None), largest


@needs_qemu
def test_mil_and_pil_equal_sil_within_the_tolerances_and_a_broken_gain_fails(fmus, tmp_path):
    sil = tl.B2BSide(fmus)
    runs = {}
    for name, side in {"mil": tl.B2BSide(fmus, stage="mil"), "pil": tl.B2BSide(fmus, stage="pil"),
                       "broken": tl.B2BSide(fmus, stage="mil", gain=(0, 2, 1.01))}.items():
        runs[name] = tl.b2b([CASE], reference=sil, candidate=side, tolerances={"default": TOLERANCE}, stop_time=STOP,
                            out=tmp_path / name)
    for name in ("mil", "pil"):
        result = runs[name].results[0]
        first, largest = _first_outside(tmp_path / name / "lkf_traj1_dlqr_reference.mcap",
                                        tmp_path / name / "lkf_traj1_dlqr_candidate.mcap")
        assert runs[name].ok and first is None, (name, runs[name].table())
        assert max(result.deviation.values()) == largest
        assert result.per_tick[0] is None and result.per_tick[1] > 0  # SIL in process; the candidate's round trip timed
        assert runs[name].changes[0] == f"controller run as SIL -> {name.upper()}"
    broken = runs["broken"]
    first, _ = _first_outside(tmp_path / "broken" / "lkf_traj1_dlqr_reference.mcap",
                              tmp_path / "broken" / "lkf_traj1_dlqr_candidate.mcap")
    worst = broken.results[0].worst()
    assert not broken.ok and first is not None and worst.first_outside == pytest.approx(first, abs=1e-9)
    assert broken.changes[0] == "controller run as SIL -> MIL, K[0,2] x 1.01"


@needs_qemu
def test_the_pil_server_is_aarch64_code_and_refuses_a_wrong_token(fmus, tmp_path):
    from tiltload.master.app.loop.thesis import default_system, loop_metrics
    from tiltload.master.app.regression import pil
    from tiltload.master.engine.run import run_system

    server = pil.build_server("aarch64-linux")
    header = server.read_bytes()[:20]
    assert header[:4] == b"\x7fELF" and int.from_bytes(header[18:20], "little") == 183  # EM_AARCH64
    with pil.served(fmus / "TiltloadController.fmu", "aarch64-linux") as host:
        wrong = tmp_path / "wrong"
        wrong.write_text("not the secret, but long enough")
        wrong.chmod(0o600)
        system = default_system(fmus, "fsi", 1, "dlqr", 1)
        system.instance("controller").remote, system.instance("controller").token_file = host.address, wrong
        result = run_system(system, 0.12, None, loop_metrics(), progress=False)
        assert result.error is not None and "refused the token" in result.error, result.error
        system.instance("controller").token_file = host.token_file  # the right one: the same server serves it
        result = run_system(system, 0.12, None, loop_metrics(), progress=False)
        assert result.error is None and result.ticks == 10


@pytest.mark.parametrize(("extra", "words"), [
    (["--candidate-stage", "mil", "--candidate-controller", "x.fmu"], "controller x.fmu does not exist"),
    (["--candidate-stage", "board"], "argument --candidate-stage: invalid choice: 'board'"),
])
def test_stages_that_cannot_run_are_one_line(extra, words, fmus, tmp_path, capsys):
    try:
        code = main(["b2b", "--cases", "reproduction", "--reference-fmus", str(fmus), "--candidate-fmus", str(fmus),
                     "--stop-time", "0.1", "--out", str(tmp_path / "b2b"), *extra])
    except SystemExit as done:
        code = done.code
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and words in err, err


def test_a_gain_change_outside_mil_and_a_mil_controller_fmu_are_refused(fmus, tmp_path):
    fmu = tmp_path / "mine.fmu"
    fmu.write_bytes(b"")
    with pytest.raises(tl.TiltloadError, match="gain change applies to the mil stage"):
        tl.b2b([CASE], candidate={"fmus": fmus, "stage": "pil", "gain": (0, 2, 1.01)}, out=tmp_path)
    with pytest.raises(tl.TiltloadError, match="a controller FMU has no Python form"):
        tl.b2b([CASE], candidate={"fmus": fmus, "stage": "mil", "controller": str(fmu)}, out=tmp_path)
    with pytest.raises(TypeError, match="candidate must be a tiltload.B2BSide"):
        tl.b2b([CASE], candidate=3, out=tmp_path)



def test_tl_serve_checks_each_step_against_the_model(fmus):
    """tl_serve built for this machine: a step that sets an output is refused (the session ends), one line."""
    import ctypes

    from tiltload.master.app.regression import pil
    from tiltload.master.engine.errors import ExecutionError
    from tiltload.master.engine.fmi.model_description import read_fmu
    from tiltload.master.engine.isolation.hosting import remote_fmu
    from tiltload.native_fmu.compile import host_platform

    fmu = fmus / "TiltloadController.fmu"
    md = read_fmu(fmu, "controller")
    with pil.served(fmu, host_platform()) as host:
        slave = remote_fmu("controller", fmu, md, host.address, host.token_file)
        try:
            slave.initialize({"controller": "dlqr", "estimator": "none"})
            output = slave.outputs["Real"][0].valueReference
            slave.setters["Real"](None, (ctypes.c_uint * 1)(output), 1, (ctypes.c_double * 1)(1.0))
            with pytest.raises(ExecutionError, match="a step sets a variable that is not an input of this model"):
                slave.do_step(0.0, 0.012)
        finally:
            slave.close()
