"""tiltload.Case(controller=MyController): a Python controller class wrapped into an FMU as `tiltload wrap` wraps it
(natively when it traces, else by pythonfmu), built once per content. A run with the class equals, metric for metric
and bit for bit, a run with the FMU the command wraps from the same class; what cannot be wrapped is a TiltloadError
of one line."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
import tiltload as tl
from tiltload.master.app.cli import main
from tiltload.master.app.wrap import class_fmu

ROOT = Path(__file__).resolve().parents[2]
TRACED = ROOT / "docs" / "examples" / "hover_lqr_traced.py"  # step written in plain numpy, traceable
PLAIN = ROOT / "docs" / "examples" / "hover_lqr.py"  # step with numpy's clip: pythonfmu only
RUN = {"scenario": "fsi", "trajectory": 0, "stop_time": 1.5, "no_gusts": True}


def _class(path: Path, name: str) -> type:
    """The class of a file, imported as a user's script imports it (registered, so its source file is known)."""
    module_name = f"user_{path.stem}"
    spec = importlib.util.spec_from_file_location(module_name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    return getattr(module, name)


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """A machine cache of the test's own: every wrap here is built anew once."""
    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _is_pythonfmu(fmu: Path) -> bool:
    with zipfile.ZipFile(fmu) as z:
        return "resources/slavemodule.txt" in z.namelist()


def test_a_traceable_class_runs_as_the_native_fmu_wrap_makes_and_is_built_once(pipeline_fmus, cache, tmp_path, monkeypatch):
    fmus = pipeline_fmus["TiltloadPlant"].parent
    cls = _class(TRACED, "HoverLQRTraced")
    case = tl.Case(controller=cls, fmus=fmus, **RUN)
    fmu = Path(case.controller)
    assert fmu.name == "HoverLQRTraced.fmu" and fmu.is_relative_to(cache) and not _is_pythonfmu(fmu)
    with_class = tl.run(case, out=tmp_path / "class", no_plots=True)
    assert "HoverLQRTraced" in with_class.log.name  # the log names the class

    wrapped = tmp_path / "cli" / "hover_lqr_traced.fmu"
    assert main(["wrap", "--native", str(TRACED), "--out", str(wrapped)]) == 0
    with_cli = tl.run(controller=str(wrapped), fmus=fmus, no_log=True, **RUN)
    assert with_class.metrics == with_cli.metrics and with_class.ticks == with_cli.ticks > 100

    def no_build(*args, **kwargs):
        raise AssertionError("built again")
    monkeypatch.setattr(class_fmu, "_build", no_build)
    assert tl.Case(controller=tl.PythonController(cls), fmus=fmus, **RUN).controller == str(fmu)  # the cached one


_RUN_IN_A_PROCESS = """
import importlib.util, json, sys
import tiltload as tl
from tiltload.master.engine.fmi.pythonfmu_guard import exit_now
path, fmus, controller = sys.argv[1:4]
spec = importlib.util.spec_from_file_location("user_hover_lqr", path)
module = importlib.util.module_from_spec(spec)
sys.modules["user_hover_lqr"] = module
spec.loader.exec_module(module)
run = dict(scenario="fsi", trajectory=0, stop_time=1.5, no_gusts=True, fmus=fmus, no_log=True)
result = tl.run(controller=module.HoverLQR if controller == "class" else controller, **run)
print(json.dumps({"metrics": result.metrics, "controller": str(result.case.controller)}))
sys.stdout.flush()
exit_now(0)
"""


def test_a_class_that_does_not_trace_runs_as_the_pythonfmu_fmu_wrap_makes(pipeline_fmus, cache, tmp_path):
    """Each run in a process of its own: two pythonfmu FMUs of one model identifier cannot share a process."""
    fmus = str(pipeline_fmus["TiltloadPlant"].parent)
    wrapped = tmp_path / "hover_lqr.fmu"
    assert main(["wrap", str(PLAIN), "--out", str(wrapped)]) == 0

    def run(controller: str) -> dict:
        done = subprocess.run([sys.executable, "-c", _RUN_IN_A_PROCESS, str(PLAIN), fmus, controller], capture_output=True,
                              text=True, cwd=tmp_path)
        assert done.returncode == 0, done.stderr[-2000:]
        return json.loads(done.stdout.strip().splitlines()[-1])
    with_class, with_cli = run("class"), run(str(wrapped))
    assert Path(with_class["controller"]).name == "HoverLQR.fmu" and _is_pythonfmu(Path(with_class["controller"]))
    assert with_class["metrics"] == with_cli["metrics"] and len(with_class["metrics"]) >= 8


UNTRACEABLE = """
class Bang:
    inputs = ["exact_z", "z_ref"]

    def step(self, t, inputs):
        if inputs["z_ref"] > inputs["exact_z"]:
            return 10.0, 10.0, 0.0, 0.0
        return 9.0, 9.0, 0.0, 0.0
"""

INIT_RAISES = """
class Broken:
    inputs = ["exact_z"]

    def __init__(self):
        self.gain = 1.0 / 0.0

    def step(self, t, inputs):
        return 0.0, 0.0, 0.0, 0.0
"""


def _one_line_error(**case) -> str:
    with pytest.raises(tl.TiltloadError) as err:
        tl.Case(**case)
    assert "\n" not in str(err.value)
    return str(err.value)


def test_what_cannot_be_wrapped_is_one_line(cache, tmp_path):
    (tmp_path / "bang.py").write_text(UNTRACEABLE)
    (tmp_path / "broken.py").write_text(INIT_RAISES)
    bang, broken = _class(tmp_path / "bang.py", "Bang"), _class(tmp_path / "broken.py", "Broken")

    forced = _one_line_error(controller=tl.PythonController(bang, native=True))
    assert "Bang.step cannot be traced at line 6" in forced and "np.where(condition, a, b)" in forced
    assert "FMI 2.0 only" in _one_line_error(controller=bang, fmi=3)  # pythonfmu's route has no FMI 3.0
    for native in (None, True, False):  # __init__ runs before any route builds
        said = _one_line_error(controller=tl.PythonController(broken, native=native))
        assert "Broken(): __init__ raised ZeroDivisionError" in said and "line 6" in said

    class NoStep:
        inputs = ["exact_z"]
    assert "has no step(t, inputs) method" in _one_line_error(controller=NoStep)

    class Nested:
        inputs = ["exact_z"]

        def step(self, t, inputs):
            return 0.0, 0.0, 0.0, 0.0
    assert "not at the top level" in _one_line_error(controller=Nested)
    assert not any(cache.rglob("*.fmu"))  # nothing was built for any of them
    with pytest.raises(TypeError, match="Case.controller"):
        tl.Case(controller=bang())  # an instance: a wrong type
    with pytest.raises(TypeError, match="native"):
        tl.PythonController(bang, native="yes")
