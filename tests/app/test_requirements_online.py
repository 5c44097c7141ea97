"""Requirements monitored in the loop agree bit for bit with the offline check of the run's log; the /requirements
channel is the robustness the offline evaluator gives at every tick; --stop-on-violation ends the run at a FAIL that
can no longer change, the log saying why, and the offline check of that log finds the same FAIL."""

from __future__ import annotations

import json

import numpy as np
import pytest
from tiltload.master.app.cli import main
from tiltload.master.app.loop.thesis import default_system
from tiltload.master.engine.log import reader as log_reader
from tiltload.master.engine.requirement.check import build_trace, check_log, log_series
from tiltload.master.engine.requirement.files import from_option
from tiltload.master.engine.requirement.observer import RequirementObserver
from tiltload.master.engine.requirement.stl import Evaluator
from tiltload.master.engine.run import run_system

REQS = ["track: always[2:inf] abs(plant.x - scenario.x_ref) < 0.3",
        "thrust: always (controller.f_R >= 0 and controller.f_R <= 30)",
        "zse: always (plant.alpha_R_dot >= controller.est_alpha_R_dot_lo and plant.alpha_R_dot <= controller.est_alpha_R_dot_hi)",
        "swing: always[0:3] abs(plant.phi) < 0.01",
        "resp: always[0:4] (abs(plant.y - scenario.y_ref) > 0.05 implies eventually[0:1] abs(plant.y - scenario.y_ref) < 0.2)",
        "long: eventually[0:20] plant.z > 100"]


def _same(a, b) -> bool:
    return a == b or (a is not None and b is not None and np.isnan(a) and np.isnan(b))


@pytest.fixture(scope="module")
def online_run(fmus, tmp_path_factory):
    reqs = [from_option(r) for r in REQS]
    obs = RequirementObserver(reqs)
    log = tmp_path_factory.mktemp("online") / "zse.mcap"
    res = run_system(default_system(fmus, "zse", 1, "mixed", 1), 6.0, log, progress=False, observers_extra=[obs])
    assert res.error is None
    return reqs, obs, log


def test_online_and_offline_agree_bit_for_bit(online_run):
    reqs, obs, log = online_run
    offline = check_log(log, reqs)
    assert {r.verdict for r in offline} >= {"PASS", "FAIL", "INCONCLUSIVE"}  # the comparison covers each kind
    for on, off in zip(obs.results, offline):
        assert on.name == off.name and on.verdict == off.verdict
        assert _same(on.robustness, off.robustness) and on.first_violation == off.first_violation
        assert on.values == off.values and on.bounds == off.bounds
    meta = log_reader.read_metadata(log)["requirements"]
    assert meta["thrust"].startswith("PASS") and meta["long"] == "INCONCLUSIVE"


def test_the_channel_is_the_robustness_at_every_tick(online_run):
    reqs, _, log = online_run
    messages = log_reader.read(log)
    channel = messages["/requirements"]
    series, _ = log_series({k: v for k, v in messages.items() if k != "/requirements"})
    for req in reqs:
        trace = build_trace(series, req.signals)
        want = Evaluator(trace)(req.formula)
        got = np.array([m[req.name] for m in channel][:len(want)])
        assert np.array_equal(got, want)  # inf where a window reaches past the end, as the evaluator has it


def test_stop_on_violation(fmus, tmp_path, capsys):
    reqs = tmp_path / "r.yaml"
    reqs.write_text('requirements:\n  - {name: swing, formula: "always abs(plant.phi) < 0.01"}\n'
                    '  - {name: thrust, bounds: {signal: controller.f_R, min: 0, max: 30}}\n')
    code = main(["run", "--scenario", "fsi", "--stop-time", "20", "--fmus", str(fmus), "--out", str(tmp_path), "--name", "s",
                 "--no-plots", "--quiet", "--requirements", str(reqs), "--stop-on-violation"])
    out, err = capsys.readouterr()
    assert code == 1 and "requirement 'swing' violated" in err and "--stop-on-violation" in err
    log = tmp_path / "s.mcap"
    stopped_at = log_reader.check(log).intact_until
    assert stopped_at < 10  # the run ended long before its 20 s
    off = {r.name: r for r in check_log(log, reqs)}
    assert off["swing"].verdict == "FAIL" and off["swing"].first_violation < stopped_at
    assert off["thrust"].verdict == "INCONCLUSIVE"  # a whole-run bound is open when the run stopped early
    assert main(["check", "--json", str(reqs), str(log)]) == 1
    results = json.loads(capsys.readouterr().out)["logs"][0]["results"]
    assert [r["verdict"] for r in results] == ["FAIL", "INCONCLUSIVE"]


def test_unknown_signal_before_the_run(fmus, tmp_path, capsys):
    reqs = tmp_path / "r.yaml"
    reqs.write_text('requirements:\n  - {name: a, formula: "always plant.phii < 1"}\n')
    assert main(["run", "--scenario", "fsi", "--stop-time", "1", "--fmus", str(fmus), "--out", str(tmp_path), "--quiet",
                 "--no-plots", "--requirements", str(reqs)]) == 2
    err = capsys.readouterr().err
    assert "did you mean plant.phi" in err and err.count("\n") == 1


def test_the_requirements_figure(online_run, tmp_path):
    from tiltload.master.app.views.plot import requirement_figure
    from tiltload.master.engine.requirement.check import intervals

    _, _, log = online_run
    (path,) = requirement_figure(log, tmp_path)
    assert path.name == "zse_requirements.png" and path.stat().st_size > 10_000
    t = np.arange(8) * 0.5
    assert intervals(t, np.array([0, 1, 1, 0, 0, 1, 0, 1], bool)) == [(0.5, 1.0), (2.5, 2.5), (3.5, 3.5)]
    assert intervals(t, np.zeros(8, bool)) == []


def test_online_and_offline_agree_with_log_every(fmus, tmp_path):
    """A log of every 4th step: the observer sees the steps the log holds."""
    reqs = [from_option(r) for r in REQS]
    obs = RequirementObserver(reqs, log_every=4)
    log = tmp_path / "every4.mcap"
    res = run_system(default_system(fmus, "zse", 1, "mixed", 1), 3.0, log, progress=False, observers_extra=[obs], log_every=4)
    assert res.error is None
    offline = check_log(log, reqs)
    assert [(r.verdict, r.robustness, r.first_violation, r.values) for r in obs.results] == \
        [(r.verdict, r.robustness, r.first_violation, r.values) for r in offline]
    assert any(r.robustness is not None for r in offline)
