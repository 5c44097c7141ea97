"""`tiltload wrap`: a user's Python controller as a contract-conforming FMU."""

from __future__ import annotations

from pathlib import Path

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu
from tiltload.master.app.cli import main
from tiltload.master.engine.fmi.pythonfmu_guard import pin
from tiltload.master.engine.log import reader as log_reader

EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "examples" / "hover_lqr.py"


@pytest.fixture(scope="module")
def wrapped(tmp_path_factory):
    out = tmp_path_factory.mktemp("wrap") / "hover_lqr.fmu"
    assert main(["wrap", str(EXAMPLE), "--out", str(out)]) == 0
    pin(out)
    return out


def test_the_example_wraps_into_a_valid_fmu_with_exactly_its_ports(wrapped):
    assert validate_fmu(str(wrapped)) == []
    md = read_model_description(str(wrapped))
    by = {v.causality: sorted(x.name for x in md.modelVariables if x.causality == v.causality) for v in md.modelVariables}
    states = ["x", "y", "z", "phi", "theta", "psi", "gamma_1", "gamma_2", "alpha_R", "alpha_L"]
    states += [f"{s}_dot" for s in states]
    assert by["input"] == sorted([f"exact_{s}" for s in states] + ["x_ref", "y_ref", "z_ref"])
    assert by["output"] == ["f_L", "f_R", "tau_L", "tau_R"]
    assert by["parameter"] == ["position_weight"]
    assert md.coSimulation.modelIdentifier == "HoverLQR" and float(md.defaultExperiment.stepSize) == 0.012
    units = {v.name: v.unit for v in md.modelVariables}
    assert units["exact_x"] == "m" and units["exact_phi_dot"] == "rad/s" and units["f_R"] == "N" and units["tau_L"] == "N.m"
    assert {u.name for u in md.unitDefinitions} == {"m", "m/s", "rad", "rad/s", "N", "N.m"}


def test_the_wrapped_controller_holds_hover_through_tiltload_run(wrapped, pipeline_fmus, tmp_path, capsys):
    fmus = pipeline_fmus["TiltloadPlant"].parent
    code = main(["run", "--controller", str(wrapped), "--scenario", "fsi", "--trajectory", "0", "--stop-time", "3",
                 "--fmus", str(fmus), "--out", str(tmp_path), "--quiet", "--no-plots", "--no-gusts"])
    assert code == 0, capsys.readouterr().err
    plant = log_reader.read(next(tmp_path.glob("*.mcap")), topics=["/plant"])["/plant"]
    assert max(abs(m[a]) for m in plant[-50:] for a in "xyz") < 0.01


BAD = {
    "unknown_port": ("class C:\n    inputs = ['ref_x']\n    def step(self, t, i):\n        return 0, 0, 0, 0\n",
                     "'ref_x' is not a port of the controller contract (did you mean 'x_ref'?)"),
    "no_step": ("class C:\n    inputs = ['x_ref']\n", "defines 0 classes with a step method"),
    "two_classes": ("class A:\n    inputs = ['x_ref']\n    def step(self, t, i):\n        return 0, 0, 0, 0\n"
                    "class B(A):\n    pass\n", "name one with --class"),
    "period": ("class C:\n    inputs = ['x_ref']\n    period = 0.02\n    def step(self, t, i):\n        return 0, 0, 0, 0\n",
               "must be a whole multiple of the 12 ms tick"),
    "no_inputs": ("class C:\n    def step(self, t, i):\n        return 0, 0, 0, 0\n", "inputs must be a non-empty list"),
    "import_error": ("import no_such_module_anywhere\n",
                     "importing import_error.py failed at line 1 (`import no_such_module_anywhere`): No module named"),
    "bad_parameter": ("class C:\n    inputs = ['x_ref']\n    parameters = {'k': float('nan')}\n    def step(self, t, i):\n"
                      "        return 0, 0, 0, 0\n", "parameters: k = nan must be a finite number"),
    "parameter_clash": ("class C:\n    inputs = ['x_ref']\n    parameters = {'f_R': 1.0}\n    def step(self, t, i):\n"
                        "        return 0, 0, 0, 0\n", "'f_R' must be an identifier that is not a port name"),
    # both routes run __init__ and one step on the trim at wrap time: a class that cannot run is no FMU (issue 65)
    "init_raises": ("class C:\n    inputs = ['x_ref']\n    def __init__(self):\n        self.k = 1 / 0\n"
                    "    def step(self, t, i):\n        return 0, 0, 0, 0\n", "C(): __init__ raised ZeroDivisionError"),
    "step_raises": ("class C:\n    inputs = ['x_ref']\n    def step(self, t, i):\n        return i['y_ref'], 0, 0, 0\n",
                    "C.step fails on the trim at t = 0 at line 4 (`return i['y_ref'], 0, 0, 0`): KeyError"),
    "step_returns_three": ("class C:\n    inputs = ['x_ref']\n    def step(self, t, i):\n        return 0, 0, 0\n",
                           "it must return 4 finite numbers"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_controller_that_breaks_the_contract_is_refused_in_one_line(case, tmp_path, capsys):
    source, needle = BAD[case]
    path = tmp_path / f"{case}.py"
    path.write_text(source)
    assert main(["wrap", str(path)]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1 and "Traceback" not in err, err
    assert not path.with_suffix(".fmu").exists()


@pytest.mark.parametrize("name, needle", [("missing.py", "no such file"), ("notes.txt", "is not a Python file")])
def test_a_missing_or_non_python_file_is_refused(tmp_path, capsys, name, needle):
    path = tmp_path / name
    if name.endswith(".txt"):
        path.write_text("hello")
    assert main(["wrap", str(path)]) == 2
    assert needle in capsys.readouterr().err
