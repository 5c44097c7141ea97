"""The LMI designs shipped with tiltload: used only when made on this very model and when every LMI holds at their
point here; the controller FMU's first build needs no synthesis; `tiltload design` says where a design comes from."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from tiltload.controller_fmu.design import artifact, lmi, shipped
from tiltload.controller_fmu.design.lmi_check import EPS_REGION, VARPI_REGION
from tiltload.controller_fmu.design.problems import problem
from tiltload.controller_fmu.design.synthesize import design
from tiltload.master.app.cli import main


def no_synthesis(*args, **kwargs):
    raise AssertionError("an LMI synthesis ran although a shipped design fits")


@pytest.mark.parametrize("kind, d", shipped.SHIPPED)
def test_every_shipped_design_holds_on_this_model(kind, d, monkeypatch):
    """The gain comes from the point, checked here: its poles in both regions, every LMI positive definite."""
    monkeypatch.setattr(lmi, "synthesize", no_synthesis)
    lines = []
    found = shipped.find(kind, shipped.TC, loop_delay=d, progress=lines.append)
    assert found is not None and found.origin == "shipped", lines
    poles = np.linalg.eigvals(found.A - found.B @ found.K)  # the model computed here, the gain derived here
    assert poles.real.min() > EPS_REGION and np.abs(poles).max() < VARPI_REGION
    assert all(v > 0 for v in found.report["lmi_min_eig"].values()) and len(found.report["lmi_min_eig"]) == (6 if kind == "mixed" else 4)
    stored = artifact.load(shipped.path(kind, loop_delay=d))
    assert np.allclose(found.K, stored.K, rtol=1e-9, atol=1e-12)  # the file's gain is the one its point gives
    assert found.report["check_seconds"] < 1.0  # the check is arithmetic, not a solve (milliseconds when quiet)


def _tampered(tmp_path, monkeypatch, edit) -> None:
    folder = tmp_path / "shipped"
    shutil.copytree(shipped.FOLDER, folder)
    path = folder / "mixed-d1.json"
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))
    monkeypatch.setattr(shipped, "FOLDER", folder)


def test_a_point_that_violates_an_lmi_is_refused(tmp_path, monkeypatch):
    """X scaled down: the pole-region LMIs are scale-free, the H-infinity LMI's identity blocks are not."""
    _tampered(tmp_path, monkeypatch, lambda d: d["lmi_point"].update(P=(0.2 * np.array(d["lmi_point"]["P"])).tolist()))
    lines = []
    assert shipped.find("mixed", shipped.TC, loop_delay=1, progress=lines.append) is None
    assert "refused" in lines[0] and "violates the LMIs" in lines[0] and "H-infinity (3.39)" in lines[0], lines


def test_a_gain_whose_poles_leave_the_regions_is_refused(tmp_path, monkeypatch):
    """The derived gain is what counts: Y zeroed gives K = 0, the open loop, unstable."""
    def zero_y(d):
        d["lmi_point"]["Y"] = np.zeros_like(np.array(d["lmi_point"]["Y"])).tolist()
    _tampered(tmp_path, monkeypatch, zero_y)
    lines = []
    assert shipped.find("mixed", shipped.TC, loop_delay=1, progress=lines.append) is None
    assert "refused" in lines[0], lines


@pytest.mark.parametrize("edit, needle", [
    (lambda d: d.update(A=(np.array(d["A"]) * (1 + 1e-6)).tolist()), "its A differs"),
    (lambda d: d["lmi_point"].update(gamma_sq=30.0**2), "gamma~ 900"),
    (lambda d: d.update(Tc=0.01), "T_c = 0.01 s"),
])
def test_a_design_made_on_another_problem_is_not_used(tmp_path, monkeypatch, edit, needle):
    _tampered(tmp_path, monkeypatch, edit)
    lines = []
    assert shipped.find("mixed", shipped.TC, loop_delay=1, progress=lines.append) is None
    assert needle in lines[0], lines


def test_a_malformed_point_is_refused(tmp_path, monkeypatch):
    _tampered(tmp_path, monkeypatch, lambda d: d["lmi_point"].update(X=[[float("nan")]]))
    lines = []
    assert shipped.find("mixed", shipped.TC, loop_delay=1, progress=lines.append) is None
    assert "refused" in lines[0], lines


def test_the_controller_fmu_needs_no_synthesis_from_an_empty_cache(tmp_path, monkeypatch):
    """A new user's first build: the six gains (DLQR in 0.1 s, the mixed ones shipped), no SDPA."""
    from tiltload.controller_fmu.fmu.build import bundle

    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "empty"))
    monkeypatch.setattr(lmi, "synthesize", no_synthesis)
    lines = []
    b = bundle(progress=lines.append)
    assert sum("the shipped one" in line for line in lines) == 3
    for d in (0, 1, 2):
        sys, _, _ = problem("mixed", shipped.TC, loop_delay=d)
        poles = np.linalg.eigvals(sys.A - sys.B @ b[f"K_mixed_d{d}"])
        assert poles.real.min() > EPS_REGION and np.abs(poles).max() < VARPI_REGION


def test_without_shipped_designs_the_mixed_one_is_synthesized(tmp_path, monkeypatch):
    """TILTLOAD_SHIPPED_DESIGNS=0 (what baseline_spread.py emulates): the cache, then a synthesis."""
    monkeypatch.setenv("TILTLOAD_SHIPPED_DESIGNS", "0")
    monkeypatch.setattr(lmi, "synthesize", no_synthesis)
    with pytest.raises(AssertionError, match="synthesis ran"):
        design("mixed", use_cache=True, progress=lambda _: None)


def test_design_command_says_where_the_design_comes_from(tmp_path, monkeypatch, capsys):
    """A stored synthesis time is never printed as if the synthesis had just run."""
    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(lmi, "synthesize", no_synthesis)
    assert main(["design", "--controller", "mixed", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "shipped with tiltload, its LMIs checked here in" in out and "synthesized now" not in out, out
    assert "measured 15.3" in out  # the norms measured here on the closed loop
    for expected in ("synthesized now in", "from the cache (synthesized earlier in"):  # DLQR: made, then cached
        assert main(["design", "--controller", "dlqr", "--out", str(tmp_path)]) == 0
        assert expected in capsys.readouterr().out
