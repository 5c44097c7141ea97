"""`tiltload check` and check_log on logs of known signals: verdicts, robustness and first violations computed here
from the signals themselves; the trace on the tick from instances of different rates; the sugar against the STL it
stands for; every kind of bad input one line and exit 2."""

from __future__ import annotations

import json

import numpy as np
import pytest
from support.synthetic_log import write_log
from tiltload.master.app.cli import main
from tiltload.master.engine.requirement.check import check_log
from tiltload.master.engine.requirement.files import RequirementError, from_option, load

TICK = 0.012
N = 1001  # 12 s


def _signals():
    t = np.arange(N) * TICK  # the plant's times as k * tick
    x = np.sin(t)
    ref = np.sin(t) + 0.01 * np.cos(3 * t)
    slow_t = np.array([0.0] + [round(k * 0.012, 12) for k in range(0, N, 2)])  # every 2nd tick, its own time, and t = 0
    u = np.concatenate([[0.0], np.linspace(0, 40, len(slow_t) - 1)])
    return t, x, ref, slow_t, u


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    t, x, ref, slow_t, u = _signals()
    return write_log(tmp_path_factory.mktemp("logs") / "run.mcap",
                     {"plant": (t, {"x": x, "z": -2 + 0 * t}), "scenario": (t, {"x_ref": ref}), "controller": (slow_t, {"f": u})},
                     stop_time=12.0)


def _held_u(t, slow_t, u):
    """The controller's value at each tick by a direct scan: its last message at or before the tick."""
    out = []
    for tk in t:
        last = None
        for ts, v in zip(slow_t, u):
            if ts <= tk + 1e-9:
                last = v
        out.append(last)
    return np.array(out)


def _reqs(tmp_path, text):
    p = tmp_path / "reqs.yaml"
    p.write_text(text)
    return p


def test_verdicts_robustness_and_first_violation(log, tmp_path):
    t, x, ref, slow_t, u = _signals()
    e = np.abs(x - ref)
    held = _held_u(t, slow_t, u)
    reqs = _reqs(tmp_path, """
requirements:
  - {name: track, formula: "always[1:10] abs(plant.x - scenario.x_ref) < 0.02", source: "by hand"}
  - {name: thrust, bounds: {signal: controller.f, min: 0, max: 30}}
  - {name: long, formula: "always[0:20] plant.z < 0"}
  - {name: zero, formula: "always plant.z <= -2"}
""")
    res = {r.name: r for r in check_log(log, reqs)}
    inside = (t >= 1 - 1e-9) & (t <= 10 + 1e-9)
    assert res["track"].verdict == "PASS" and res["track"].robustness == pytest.approx(np.min(0.02 - e[inside]), abs=1e-15)
    first = int(np.flatnonzero(held > 30)[0])
    r = res["thrust"]
    assert r.verdict == "FAIL" and r.robustness == pytest.approx(30 - held.max(), abs=1e-12)
    assert r.first_violation == pytest.approx(t[first], abs=1e-12) and r.values == {"controller.f": held[first]}
    assert res["long"].verdict == "INCONCLUSIVE" and res["long"].robustness is None  # 12 s of a 20 s horizon
    assert res["zero"].verdict == "ZERO" and res["zero"].robustness == 0.0


def test_a_killed_run_cannot_pass_but_can_fail(tmp_path):
    t = np.arange(200) * TICK
    log = write_log(tmp_path / "torn.mcap", {"plant": (t, {"z": 1.0 - t})}, finish=False)
    res = {r.name: r for r in check_log(log, [from_option("a: always plant.z > -5"), from_option("b: always plant.z > 0")])}
    assert res["a"].verdict == "INCONCLUSIVE"  # the run to its end could still go below -5
    assert res["b"].verdict == "FAIL" and res["b"].first_violation == pytest.approx(t[np.flatnonzero(1.0 - t <= 0)[0]])


def test_sugar_is_the_stl_it_expands_to(log, tmp_path):
    reqs = load(_reqs(tmp_path, """
requirements:
  - {name: b, bounds: {signal: plant.x, min: -0.9, max: 0.95, from: 1, to: 9}}
  - {name: r, response: {trigger: "plant.x > 0.9", within: 0.5, hold: 0.2, response: "plant.x < 0.99", to: 8}}
"""))
    by_hand = [from_option("b: always[1:9] (plant.x >= -0.9 and plant.x <= 0.95)"),
               from_option("r: always[0:8] (plant.x > 0.9 implies eventually[0:0.5] always[0:0.2] plant.x < 0.99)")]
    assert [r.formula for r in reqs] == [r.formula for r in by_hand]
    got, want = check_log(log, reqs), check_log(log, by_hand)
    assert [(g.verdict, g.robustness, g.first_violation) for g in got] == [(w.verdict, w.robustness, w.first_violation) for w in want]


def test_cli_table_json_and_exit_codes(log, tmp_path, capsys):
    ok = _reqs(tmp_path, 'requirements:\n  - {name: track, formula: "always[1:10] abs(plant.x - scenario.x_ref) < 0.02"}\n')
    assert main(["check", str(ok), str(log)]) == 0
    assert "track" in capsys.readouterr().out
    assert main(["check", str(log), "--formula", "f: always controller.f < 30", "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    (r,) = out["logs"][0]["results"]
    assert r["name"] == "f" and r["verdict"] == "FAIL" and r["first_violation"] > 0
    t = np.arange(100) * TICK  # a killed run of 12 s: 1.2 s in its log
    torn = write_log(tmp_path / "torn.mcap", {"plant": (t, {"z": -2 + 0 * t})}, stop_time=12.0, finish=False)
    assert main(["check", str(torn), "--formula", "g: always[0:5] plant.z < 0"]) == 3  # INCONCLUSIVE: neither 0 nor 1
    assert main(["check", str(ok), "--explain"]) == 0
    assert "always[1:10] (abs((plant.x - scenario.x_ref)) < 0.02)" in capsys.readouterr().out


@pytest.mark.parametrize("yaml_text, argv_extra, needle", [
    ('requirements:\n  - {name: a, formula: "always[0:2 plant.x > 0"}\n', [], "at column 12"),
    ('requirements:\n  - {name: a, formula: "always plant.xx > 0"}\n', [], "did you mean plant.x"),
    ('requirements:\n  - {name: a, formula: "always plnt.x > 0"}\n', [], "did you mean plant.x"),
    ('requirements:\n  - {name: a, formula: "always[3:1] plant.x > 0"}\n', [], "reversed interval"),
    ('requirements:\n  - {name: a, bounds: {signal: plant.x, max: 1, from: 5, to: 2}}\n', [], "reversed interval"),
    ('requirements:\n  - {name: a, bounds: {signal: plant.x, max: 1, from: -1}}\n', [], "negative time"),
    ('requirements:\n  - {name: a, formula: "always[0:-1] plant.x > 0"}\n', [], "negative time bound"),
    ('requirements:\n  - {name: a, formula: "always[0:30] plant.x > -5"}\n', [], "longer than any run"),
    ('requirements:\n  - {name: a, formula: "plant.x > 0", bounds: {signal: plant.x, max: 1}}\n', [], "exactly one of"),
    ('requirements:\n  - {name: a, formula: "plant.x > 0"}\n  - {name: a, formula: "plant.x > 1"}\n', [], "named twice"),
    ('requirements:\n  - {name: a, formla: "plant.x > 0"}\n', [], "unknown key 'formla'"),
    ('requirements: [\n', [], "not valid YAML at line"),
    ('r: &one {name: a, formula: "plant.x > 0"}\nrequirements: [*one]\n', [], "aliases are not accepted"),
    ('- just a list\n', [], "one key, requirements"),
])
def test_bad_input_is_one_line_and_exit_2(log, tmp_path, capsys, yaml_text, argv_extra, needle):
    reqs = _reqs(tmp_path, yaml_text)
    assert main(["check", str(reqs), str(log), *argv_extra]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1, err


def test_bad_files_and_options(log, tmp_path, capsys):
    big = tmp_path / "big.yaml"
    big.write_text("#" * ((1 << 20) + 1))
    fake = tmp_path / "fake.mcap"
    fake.write_text("requirements: []")
    cases = [(["check", str(big), str(log)], "bytes"),
             (["check", str(log), "--formula", "no colon here"], "NAME: STL"),
             (["check", str(log)], "no requirements"),
             (["check", str(tmp_path / "none.yaml"), str(log)], "no such file"),
             (["check", str(tmp_path), str(log)], "not a regular file"),
             (["check", "--formula", "a: plant.x > 0", str(tmp_path / "none.mcap")], "no such file"),
             (["check", "--formula", "a: plant.x > 0", str(fake)], "not an MCAP log")]
    for argv, needle in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert needle in err and err.count("\n") == 1, (argv, err)
    with pytest.raises(RequirementError, match="did you mean"):
        check_log(log, [from_option("a: always plant.xx > 0")])


def test_several_logs_a_signal_one_lacks_is_inconclusive_there(log, tmp_path, capsys):
    t = np.arange(300) * TICK
    other = write_log(tmp_path / "no_controller.mcap", {"plant": (t, {"x": 0 * t, "z": -2 + 0 * t})}, stop_time=12.0)
    assert main(["check", "--json", str(log), str(other), "--formula", "f: always controller.f < 50",
                 "--formula", "z: always plant.z < 0"]) == 3
    first, second = json.loads(capsys.readouterr().out)["logs"]
    assert [r["verdict"] for r in first["results"]] == ["PASS", "PASS"]
    assert [r["verdict"] for r in second["results"]] == ["INCONCLUSIVE", "PASS"]
    assert "has no signal controller.f" in second["results"][0]["why"]
    # a signal in none of the logs is a typo: exit 2, the closest names
    assert main(["check", str(log), str(other), "--formula", "f: always controller.ff < 50"]) == 2
    assert "did you mean controller.f" in capsys.readouterr().err


def test_read_columns_equals_the_message_reader(tmp_path):
    """read_columns decodes the fixed layout's doubles as the per-message reader does, bit for bit."""
    from tiltload.master.engine.log import reader as log_reader

    t = np.arange(50) * TICK
    path = write_log(tmp_path / "l.mcap", {"plant": (t, {"x": np.sin(t) * 1e-300, "y": np.cos(t)})})
    columns, _ = log_reader.read_columns(path, ["/plant"])
    messages = log_reader.read(path, ["/plant"])["/plant"]
    times, values = columns["/plant"]
    assert times.tolist() == [m["t"] for m in messages]
    assert values["x"].tolist() == [m["x"] for m in messages] and values["y"].tolist() == [m["y"] for m in messages]


def test_reproduce_verdict_table(log, tmp_path, capsys):
    from tiltload.master.app.commands.reproduce import verdict_table

    reqs = [from_option("f: always controller.f < 30"), from_option("z: always plant.z < 0")]
    assert verdict_table(reqs, [log, tmp_path / "never_ran.mcap"]) is True
    out = capsys.readouterr().out.splitlines()
    assert out[2].split() == ["f", "F", "-"] and out[3].split() == ["z", "P", "-"]
    assert out[4].startswith("  FAIL run: f, robustness")


def test_compare_verdicts(log, tmp_path):
    from tiltload.master.app.regression.compare import compare_verdicts

    t = np.arange(N) * TICK
    calmer = write_log(tmp_path / "calm.mcap", {"plant": (t, {"x": np.sin(t), "z": -2.5 + 0 * t}),
                                               "controller": (t, {"f": np.full(N, 10.0)})}, stop_time=12.0)
    reqs = [from_option("f: always controller.f < 30"), from_option("z: always plant.z < 0")]
    base, run = check_log(log, reqs), check_log(calmer, reqs)
    ok, rows = compare_verdicts(run, base, 1e-6, 1e-12)
    assert not ok and [r[-1] for r in rows] == ["VERDICT CHANGED", "DIFFERS"]  # f: FAIL -> PASS; z: 2 -> 2.5
    assert compare_verdicts(run, base, 0.3, 0)[1][1][-1] == "ok"  # 0.5 within 30 % of 2
    assert compare_verdicts(base, base, 0, 0)[0]
