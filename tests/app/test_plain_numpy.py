"""Plain numpy to C (issue 65): controllers written in numpy alone (tests/support/data/plain_numpy_corpus.py: float()
at the return, np.clip, np.where, assignment into arrays, math.*, int(), gains and states from __init__, tl.saturate,
tl.rate_limit, ...) trace unchanged, and the traced function gives what the class gives run in Python, tick by tick
with its states carried and its saturations hit; with a declared parameter set away from its default too (a gain
derived from it in __init__ is recomputed). The Python form is the oracle."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from tiltload.master.app.wrap import trace, wrap

ROOT = Path(__file__).resolve().parents[2]
CORPUS = ROOT / "tests" / "support" / "data" / "plain_numpy_corpus.py"
MODULE = wrap.load_module(CORPUS)
TICKS = 300


def _inputs(rng, k: int, walk: np.ndarray) -> dict[str, float]:
    """The trim, plus a random walk that drives the commands into their limits now and then."""
    walk += 0.02 * rng.normal(size=walk.size)
    x = MODULE.X_EQ + walk[:20] * (1.0 + 4.0 * (k % 97 < 20))
    refs = walk[20:23] + (0.8 if 150 <= k < 200 else 0.0)
    return {**dict(zip(MODULE.EXACT, map(float, x))), **dict(zip(MODULE.REFS, map(float, refs)))}


def _deviation(cls, values: dict[str, float]) -> float:
    spec = wrap.describe_class(cls, CORPUS)
    traced = trace.trace(cls, spec["parameters"], list(spec["inputs"]), CORPUS)
    assert traced.fixed == []  # every corpus __init__ traces: its parameters stay tunable
    p = np.array([values.get(n, v) for n, v in traced.parameters])
    s = np.array(traced.init(p)).ravel()
    python = cls(**{k: values.get(k, v) for k, v in spec["parameters"].items()})
    lqr = MODULE._Lqr()
    rng, walk, worst, acted = np.random.default_rng(11), np.zeros(23), 0.0, 0
    for k in range(TICKS):
        t = k * cls.period
        u = _inputs(rng, k, walk)
        mine = np.array([float(v) for v in python.step(t, dict(u))])
        theirs, s = trace.run_traced(traced, t, u, p, s)
        worst = max(worst, float(np.max(np.abs(theirs - mine))))
        acted += bool(np.max(np.abs(mine - lqr.raw(u))) > 1e-9)
    assert acted > 5, "the class's nonlinearity (a saturation, a rate limit, a state) was never exercised"
    return worst


def test_the_corpus_is_the_size_the_issue_asks():
    assert len(MODULE.CORPUS) >= 20 and "casadi" not in CORPUS.read_text()


@pytest.mark.parametrize("cls", MODULE.CORPUS, ids=lambda c: c.__name__)
def test_each_plain_numpy_controller_traces_into_what_it_computes(cls):
    assert _deviation(cls, {}) <= 1e-12


@pytest.mark.parametrize("name, values", [("GainsFromInit", {"position_scale": 1.6, "thrust_trim": 0.3}),
                                          ("IntegratorHeld", {"ki": 2.0}), ("CommandFilter", {"alpha": 0.5})])
def test_a_parameter_set_away_from_its_default_is_recomputed_through_init(name, values):
    cls = getattr(MODULE, name)
    assert _deviation(cls, values) <= 1e-12


def test_a_parameter_init_needs_the_number_of_is_fixed_and_said_so(tmp_path, capsys):
    from tiltload.master.app.cli import main

    source = tmp_path / "branchy.py"
    source.write_text("import numpy as np\n\n\nclass Branchy:\n    inputs = ['exact_z', 'z_ref']\n"
                      "    parameters = {'aggressive': 0.0}\n\n    def __init__(self, aggressive=0.0):\n"
                      "        if aggressive > 0.5:\n            self.k = 8.0\n        else:\n            self.k = 4.0\n\n"
                      "    def step(self, t, inputs):\n        e = inputs['z_ref'] - inputs['exact_z']\n"
                      "        return float(np.clip(10.2 + self.k * e, 0, 30)), 10.2, 0.0, 0.0\n")
    assert main(["wrap", "--native", str(source), "--out", str(tmp_path / "b.fmu")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == ("wrap: parameter aggressive fixed at its default in the native FMU: Branchy.__init__ needs the "
                      "number at line 9 (`if aggressive > 0.5:`); the pythonfmu route (tiltload wrap) keeps it tunable")


def test_no_third_party_warning_reaches_the_terminal(tmp_path):
    """The shipped example, wrapped natively by the command a user types: nothing on stderr."""
    done = subprocess.run([sys.executable, "-m", "tiltload.master.app.cli", "wrap", "--native",
                           str(ROOT / "docs" / "examples" / "hover_lqr.py"), "--out", str(tmp_path / "h.fmu")],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0 and done.stderr == "", done.stderr


PD = """import numpy as np


class AltitudeHold:
    inputs = ["exact_z", "z_ref", "exact_z_dot", "exact_x", "exact_y", "exact_phi", "exact_theta", "exact_psi",
              "exact_phi_dot", "exact_theta_dot", "exact_psi_dot"]

    def step(self, t, inputs):
        e = inputs["z_ref"] - inputs["exact_z"]
        f = 10.2 + 4.0 * e - 2.5 * inputs["exact_z_dot"]
        return float(np.clip(f, 0, 30)), float(np.clip(f, 0, 30)), 0.0, 0.0
"""


@pytest.mark.slow
def test_run_takes_a_class_file_wraps_it_natively_once_and_says_so(pipeline_fmus, tmp_path, capsys, monkeypatch):
    from tiltload.master.app.cli import main
    from tiltload.master.app.wrap import class_fmu

    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    source = tmp_path / "altitude_hold.py"
    source.write_text(PD)
    run = ["run", "--controller", str(source), "--scenario", "fsi", "--trajectory", "0", "--stop-time", "1.2",
           "--fmus", str(pipeline_fmus["TiltloadPlant"].parent), "--no-log", "--no-gusts"]
    assert main(run) == 0
    first = capsys.readouterr().out
    assert f"--controller {source}: wrapped as a native C FMU (traced from plain numpy)" in first.splitlines()

    def no_build(*args, **kwargs):
        raise AssertionError("wrapped again")
    monkeypatch.setattr(class_fmu, "_build", no_build)  # the same source: the cached FMU
    assert main(run) == 0
    again = capsys.readouterr().out
    metrics = [line for line in first.splitlines() if line.strip().startswith(("ISE(", "IADU("))]
    assert metrics and metrics == [line for line in again.splitlines() if line.strip().startswith(("ISE(", "IADU("))]

    assert main([*run[:2], str(tmp_path / "missing.py"), *run[3:]]) == 2
    assert capsys.readouterr().err.strip().endswith("missing.py: no such file")


def closed_loop_deviation(cls, fmus: Path, where: Path, seconds: float = 3.0, scenario: str = "fsi", trajectory: int = 1,
                          fmu: Path | None = None, diverging: bool = False) -> float:
    """The native FMU of cls (wrapped here unless given) in the closed loop (scenario, trajectory, seconds), and its
    Python form given, tick by tick, the inputs the loop gave the FMU (the sensors' and the scenario's outputs at t_k,
    from the log): the largest difference of their commands. diverging: a loop the class cannot fly to its end (a
    hover controller on a trajectory) may end with the plant's state diverged, its ticks until then compared (3 s at
    least)."""
    from tiltload.master.app.loop.thesis import default_system
    from tiltload.master.engine.log import reader as log_reader
    from tiltload.master.engine.run import run_system

    fmu = fmu or native_fmu(cls, where)
    log = where / f"{cls.__name__}_{scenario}_traj{trajectory}.mcap"
    result = run_system(default_system(fmus, scenario, trajectory, None, 1, fmu), seconds, log, progress=False)
    assert result.error is None or (diverging and "state diverged" in result.error), result.error
    if result.error:
        print(f"\n{cls.__name__} {scenario}/traj{trajectory}: {result.error}")
        seconds = 3.0  # compared until it diverged: 3 s of ticks at least
    data = log_reader.read(log, topics=["/sensors", "/scenario", "/controller"])
    python, worst = cls(), 0.0
    for sensed, scenario_out, command in zip(data["/sensors"], data["/scenario"], data["/controller"]):
        assert sensed["t"] == scenario_out["t"] == command["t"]
        inputs = {n: (sensed if n.startswith("exact_") else scenario_out)[n] for n in cls.inputs}
        mine = [float(v) for v in python.step(command["t"], inputs)]
        worst = max(worst, max(abs(m - command[n]) for m, n in zip(mine, ("f_R", "f_L", "tau_R", "tau_L"))))
    assert len(data["/controller"]) >= int(seconds / cls.period) - 1
    return worst


def native_fmu(cls, where: Path) -> Path:
    """cls wrapped by `tiltload wrap --native`, validated by FMPy."""
    from fmpy.validation import validate_fmu
    from tiltload.master.app.cli import main

    fmu = where / f"{cls.__name__}.fmu"
    assert main(["wrap", "--native", str(CORPUS), "--class", cls.__name__, "--out", str(fmu)]) == 0
    assert validate_fmu(str(fmu)) == []
    return fmu


@pytest.mark.slow
@pytest.mark.parametrize("cls", MODULE.CORPUS, ids=lambda c: c.__name__)
def test_each_native_fmu_equals_its_python_form_in_the_closed_loop(cls, fmus, tmp_path):
    assert closed_loop_deviation(cls, fmus, tmp_path) <= 1e-12




@pytest.mark.slow
@pytest.mark.parametrize("cls", MODULE.CORPUS, ids=lambda c: c.__name__)
def test_each_native_fmu_equals_its_python_form_over_the_twelve_reproduction_cases(cls, fmus, tmp_path):
    """The twelve reproduction cases (ch. 5: fsi, lkf, zse x trajectories 1, 2 x dlqr, mixed) with the corpus class as
    the controller: the case's own controller replaced, they are six loops (scenario x trajectory), each run for its
    trajectory's duration (40 s, 50 s; a hover controller that cannot fly it compared until its loop diverged). The
    largest deviation is printed (pytest -s) for the record."""
    from tiltload.master.app.regression.reproduce import CASES
    from tiltload.scenario_fmu.trajectories import DURATION

    fmu = native_fmu(cls, tmp_path)
    loops = list(dict.fromkeys((s, t) for s, t, _ in CASES))
    assert len(CASES) == 12 and len(loops) == 6
    worst = {(s, t): closed_loop_deviation(cls, fmus, tmp_path, DURATION[t], s, t, fmu=fmu, diverging=True) for s, t in loops}
    print(f"\n{cls.__name__}: largest deviation over the reproduction cases {max(worst.values()):.3g} "
          f"({', '.join(f'{s}/traj{t} {d:.3g}' for (s, t), d in worst.items())})")
    assert max(worst.values()) <= 1e-12, worst


GAIN = """import numpy as np


class Hold:
    inputs = ["exact_z", "z_ref", "exact_z_dot"]

    def __init__(self):
        self.kp = 4.0
        self.kd = 2.5

    def step(self, t, inputs):
        e = inputs["z_ref"] - inputs["exact_z"]
        f = 10.2 + self.kp * e - self.kd * inputs["exact_z_dot"]
        return float(np.clip(f, 0, 30)), float(np.clip(f, 0, 30)), 0.0, 0.0
"""


@pytest.mark.slow
def test_a_one_percent_gain_change_in_the_source_is_said_in_the_users_words(pipeline_fmus, tmp_path):
    """A baseline of a class file's run records its source: the comparison after a 1 % change of a gain names the
    parameter and the changed line of the class first, before any metric."""
    import tiltload as tl

    source = tmp_path / "hold.py"
    source.write_text(GAIN)
    run = dict(controller=str(source), scenario="fsi", trajectory=1, stop_time=1.2, no_gusts=True,
               fmus=pipeline_fmus["TiltloadPlant"].parent)
    baseline = tl.save_baseline(tl.run(**run, out=tmp_path / "a", no_plots=True), tmp_path / "hold.json")
    source.write_text(GAIN.replace("self.kp = 4.0", "self.kp = 4.04"))
    comparison = tl.compare(tl.run(**run, out=tmp_path / "b", no_plots=True), baseline)
    assert not comparison.ok
    line = GAIN.splitlines().index("        self.kp = 4.0") + 1
    assert comparison.changed_line().startswith("what changed: controller parameter kp 4.0 -> 4.04; controller class "
                                                f"line {line} `self.kp = 4.0` -> `self.kp = 4.04`; ")


TAPS = """import numpy as np


class Taps:
    inputs = ["exact_z", "z_ref"]
    parameters = {"taps": 3.0, "gain": 4.0}

    def __init__(self, taps=3.0, gain=4.0):
        self.n = int(taps)
        self.gain = gain
        self.history = np.zeros(3)

    def step(self, t, inputs):
        e = inputs["z_ref"] - inputs["exact_z"]
        total = 0.0
        for i in range(self.n):
            total = total + self.history[i]
        self.history = np.concatenate([[e], self.history[:-1]])
        return float(np.clip(10.2 + self.gain * (e + total / self.n), 0, 30)), 10.2, 0.0, 0.0
"""


def test_a_count_from_init_traces_with_its_parameters_fixed_and_said_where(tmp_path):
    """range(self.n) needs n's number: the parameters are fixed (named with the line), the count kept as the number it
    is, and the traced function still computes what the class does."""
    source = tmp_path / "taps.py"
    source.write_text(TAPS)
    cls = wrap.find_class(wrap.load_module(source), source, None)[1]
    traced = trace.trace(cls, {"taps": 3.0, "gain": 4.0}, cls.inputs, source)
    line = TAPS.splitlines().index("        for i in range(self.n):") + 1
    assert traced.fixed == ["taps", "gain"]
    assert traced.why_fixed == f"Taps.step needs the number at line {line} (`for i in range(self.n):`)"
    python, p = cls(), np.array([v for _, v in traced.parameters])
    s = np.array(traced.init(p)).ravel()
    for k in range(60):
        u = {"exact_z": 0.1 * np.sin(0.3 * k), "z_ref": 1.0 if k > 10 else 0.0}
        mine = [float(v) for v in python.step(k * 0.012, dict(u))]
        theirs, s = trace.run_traced(traced, k * 0.012, u, p, s)
        assert np.allclose(theirs, mine, rtol=0, atol=1e-12)


def test_a_campaign_takes_a_class_file_among_its_controllers(tmp_path, monkeypatch):
    """base.controllers = ["dlqr", "my_hold.py"]: the class wrapped as run --controller wraps it (here natively); its
    runs name that FMU; a class that cannot run is the spec's one line."""
    from tiltload.master.app.campaign import spec as campaign_spec
    from tiltload.master.app.case.spec_file import SpecError
    from tiltload.master.app.wrap.class_fmu import route

    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    (tmp_path / "hold.py").write_text(GAIN)
    spec = tmp_path / "c.toml"
    spec.write_text('name = "c"\n[base]\nscenario = "fsi"\ntrajectory = 1\ncontrollers = ["dlqr", "hold.py"]\n'
                    "stop_time = 1\n[vary]\nseeds = [1]\n")
    controllers = [case.controller for case in campaign_spec.load(spec).cases]
    assert len(controllers) == 2 and controllers[0] == "dlqr" and controllers[1].endswith("hold.fmu")
    assert route(Path(controllers[1])).startswith("a native C FMU")
    (tmp_path / "hold.py").write_text(GAIN.replace("self.kd = 2.5", "self.kd = 1 / 0"))
    with pytest.raises(SpecError, match=r"c.toml: base.controllers: Hold\(\): __init__ raised ZeroDivisionError"):
        campaign_spec.load(spec)


def _one_line_exit_2(argv: list[str], capsys) -> str:
    from tiltload.master.app.cli import main

    try:
        code = main(argv)
    except SystemExit as done:
        code = done.code
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


def test_falsify_takes_a_class_file_as_its_controller(tmp_path, monkeypatch, capsys):
    """base.controller = "my_hold.py": the search runs the FMU `run --controller my_hold.py` runs (the same wrapping, the
    same cached file); a class whose __init__ raises is the spec's one line, exit 2, before any search."""
    from tiltload.master.app.falsify.spec import load
    from tiltload.master.app.wrap.class_fmu import controller_fmu_of_file, route

    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    (tmp_path / "hold.py").write_text(GAIN)
    spec = tmp_path / "f.toml"
    spec.write_text('name = "f"\n[base]\nscenario = "fsi"\ntrajectory = 1\ncontroller = "hold.py"\nstop_time = 2\n'
                    '[[requirements]]\nname = "z"\nformula = "always (abs(plant.z) < 5)"\n'
                    '[[search]]\nname = "m"\ntarget = "plant.m_L"\nrange = [0.1, 0.3]\n[budget]\nsimulations = 2\n')
    controller = Path(load(spec).controller)
    assert controller == controller_fmu_of_file(tmp_path / "hold.py") and controller.name == "hold.fmu"
    assert route(controller).startswith("a native C FMU")
    (tmp_path / "hold.py").write_text(GAIN.replace("self.kd = 2.5", "self.kd = 1 / 0"))
    err = _one_line_exit_2(["falsify", str(spec), "--out", str(tmp_path / "o")], capsys)
    assert "f.toml: base.controller: Hold(): __init__ raised ZeroDivisionError" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_b2b_takes_a_class_file_on_either_side(pipeline_fmus, tmp_path, monkeypatch, capsys):
    """b2b --reference-controller my_hold.py --candidate-controller my_hold_1pc.py (kp 1 % larger): each wrapped on the fly,
    the route said; the reference's logged commands are what the class computes in Python from the logged inputs (the
    oracle); the candidate leaves its tubes and what changed names kp. The API's sides take the file the same way."""
    import tiltload as tl
    from tiltload.master.app.cli import main
    from tiltload.master.engine.log import reader as log_reader

    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    fmus = pipeline_fmus["TiltloadPlant"].parent
    (tmp_path / "hold.py").write_text(GAIN)
    (tmp_path / "hold_1pc.py").write_text(GAIN.replace("self.kp = 4.0", "self.kp = 4.04"))
    (tmp_path / "cases.toml").write_text('cases = [{scenario = "fsi", trajectory = 1}]\n')
    out = tmp_path / "b2b"
    code = main(["b2b", "--cases", str(tmp_path / "cases.toml"), "--reference-fmus", str(fmus), "--candidate-fmus", str(fmus),
                 "--reference-controller", str(tmp_path / "hold.py"), "--candidate-controller", str(tmp_path / "hold_1pc.py"),
                 "--stop-time", "1.2", "--out", str(out)])
    lines = capsys.readouterr().out.splitlines()
    assert code == 1, lines
    assert f"the candidate's controller {tmp_path / 'hold_1pc.py'}: wrapped as a native C FMU (traced from plain numpy)" in lines
    assert any(line.startswith("what changed: controller parameter kp 4.0 -> 4.04") for line in lines), lines
    module = wrap.load_module(tmp_path / "hold.py")
    python, worst, ticks = module.Hold(), 0.0, 0
    data = log_reader.read(out / "fsi_traj1_hold_vs_hold_1pc_reference.mcap", topics=["/sensors", "/scenario", "/controller"])
    for sensed, scenario, command in zip(data["/sensors"], data["/scenario"], data["/controller"]):
        inputs = {n: (sensed if n.startswith("exact_") else scenario)[n] for n in module.Hold.inputs}
        mine = [float(v) for v in python.step(command["t"], inputs)]
        worst = max(worst, max(abs(m - command[n]) for m, n in zip(mine, ("f_R", "f_L", "tau_R", "tau_L"))))
        ticks += 1
    assert ticks > 90 and worst <= 1e-12

    same = tl.b2b([{"scenario": "fsi", "trajectory": 1}], reference={"fmus": fmus, "controller": str(tmp_path / "hold.py")},
                  candidate={"fmus": fmus, "controller": str(tmp_path / "hold.py")}, stop_time=0.6, out=tmp_path / "api")
    assert same.ok
    (tmp_path / "broken.py").write_text(GAIN.replace("self.kd = 2.5", "self.kd = 1 / 0"))
    with pytest.raises(tl.TiltloadError, match=r"Hold\(\): __init__ raised ZeroDivisionError"):
        tl.b2b([{"scenario": "fsi", "trajectory": 1}], reference={"fmus": fmus},
               candidate={"fmus": fmus, "controller": str(tmp_path / "broken.py")}, stop_time=0.6, out=tmp_path / "api2")
    err = _one_line_exit_2(["b2b", "--candidate-controller", str(tmp_path / "missing.py"), "--out", str(out)], capsys)
    assert "controller" in err and "missing.py does not exist" in err


PLUGIN_TEST = """
from hold import Hold
from tiltload.master.app.wrap.class_fmu import route


def test_hold(tiltload_run, tiltload_baseline, tiltload_controller):
    assert route(tiltload_controller("hold.py", native=True)).startswith("a native C FMU")
    assert route(tiltload_controller(Hold, native=True)).startswith("a native C FMU")  # the class, from its file
    assert route(tiltload_controller("hold.py")).startswith("a pythonfmu FMU")  # the default: as tiltload wrap
    tiltload_baseline.check(tiltload_run(controller="hold.py", native=True, scenario="fsi", trajectory=1,
                                         stop_time=1.2, no_gusts=True))
"""


@pytest.mark.slow
def test_a_pytest_failure_after_a_one_percent_gain_change_names_the_line_and_the_parameter_first(fmus, tmp_path):
    """A user's pytest session: tiltload_run(controller="my_hold.py", native=True) against its recorded baseline; kp
    changed by 1 % in the source, the failure's first line names the parameter and the class's changed line."""
    session = tmp_path / "session"
    session.mkdir()
    (session / "hold.py").write_text(GAIN)
    (session / "test_user.py").write_text(PLUGIN_TEST)
    (session / "pytest.ini").write_text("[pytest]\n")  # the user's repository: its rootdir, where the class file is

    def pytest_session(*extra: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "pytest", "-q", "-rf", "-p", "no:cacheprovider", "--rootdir", str(session),
                               "--tiltload-fmus", str(fmus), *extra, "test_user.py"], cwd=session, capture_output=True, text=True,
                              timeout=1200, env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1",
                                                 "TILTLOAD_CACHE": str(tmp_path / "cache")})

    recorded = pytest_session("--tiltload-update-baselines")
    assert recorded.returncode == 0, recorded.stdout[-3000:] + recorded.stderr[-2000:]
    assert pytest_session().returncode == 0  # the same class: the same run
    (session / "hold.py").write_text(GAIN.replace("self.kp = 4.0", "self.kp = 4.04"))
    failed = pytest_session()
    assert failed.returncode == 1, failed.stdout[-3000:] + failed.stderr[-2000:]
    line = GAIN.splitlines().index("        self.kp = 4.0") + 1
    said = failed.stdout.splitlines()
    header = next(i for i, s in enumerate(said) if s.strip("_ ") == "test_hold")  # the failure's own section
    first = next(s for s in said[header + 1:] if s.strip())
    assert first.startswith("the run differs from its baseline; what changed: controller parameter kp 4.0 -> 4.04; "
                            f"controller class line {line} `self.kp = 4.0` -> `self.kp = 4.04`; "), first
    assert first.endswith("scenario, sensors and plant unchanged"), first
