"""`tiltload wrap --native`: a traceable Python controller as a native C FMU. Stepped by FMPy, it gives what the class
itself gives run in Python at every step (states carried, saturations, t); a snapshot restores its state; FMI 2.0 and
3.0 builds validate; what cannot be traced is refused in one line naming the line of the class; and in the closed
loop its binaries on win64 (wine) and aarch64 (qemu-user) equal linux64."""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from tiltload.master.app.cli import main

ROOT = Path(__file__).resolve().parents[2]
PI = ROOT / "tests" / "support" / "data" / "traced_pi.py"
HOVER = ROOT / "docs" / "examples" / "hover_lqr_traced.py"


def _class(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(f"traced_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return getattr(module, name)


def _wrapped(path: Path, out: Path, *extra: str) -> Path:
    assert main(["wrap", "--native", str(path), "--out", str(out), *extra]) == 0
    return out


@pytest.fixture(scope="module")
def pi_fmu(tmp_path_factory) -> Path:
    return _wrapped(PI, tmp_path_factory.mktemp("native") / "traced_pi.fmu")


class _Slave:
    """An FMI 2.0 co-simulation instance of an FMU, by FMPy."""

    def __init__(self, fmu: Path, where: Path):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.md = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=extract(str(fmu), str(where)),
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="c")
        self.slave.instantiate()
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        self.slave.exitInitializationMode()

    def step(self, t: float, h: float, inputs: dict[str, float]) -> list[float]:
        self.slave.setReal([self.vr[n] for n in inputs], list(inputs.values()))
        self.slave.doStep(t, h)
        return self.slave.getReal([self.vr[n] for n in ("f_R", "f_L", "tau_R", "tau_L")])


def _inputs(rng, names: list[str], k: int) -> dict[str, float]:
    return {n: float(np.sin(0.05 * k + i) + 0.3 * rng.normal()) for i, n in enumerate(names)}


def test_the_native_fmu_steps_as_the_class_does_in_python(pi_fmu, tmp_path):
    cls = _class(PI, "TracedPI")
    python = cls()
    fmu = _Slave(pi_fmu, tmp_path)
    rng = np.random.default_rng(7)
    saturated = 0
    for k in range(400):
        t = k * cls.period
        u = _inputs(rng, cls.inputs, k)
        u["z_ref"] = 5.0 if k < 200 else -1.0  # a step big enough to saturate the thrust (and freeze the integral)
        mine = [float(v) for v in python.step(t, dict(u))]
        python.integral = float(python.integral)  # the class run as plain Python: its state a number
        theirs = fmu.step(t, cls.period, u)
        assert np.allclose(theirs, mine, rtol=1e-12, atol=1e-12), (k, theirs, mine)
        saturated += mine[0] in (30.0 + 0.01 * np.sin(2 * np.pi * t), 0.0 + 0.01 * np.sin(2 * np.pi * t))
    assert saturated > 10  # the saturation and the frozen integral were exercised


def test_a_snapshot_restores_the_traced_state(pi_fmu, tmp_path):
    cls = _class(PI, "TracedPI")
    fmu = _Slave(pi_fmu, tmp_path)
    rng = np.random.default_rng(3)
    for k in range(50):
        fmu.step(k * cls.period, cls.period, _inputs(rng, cls.inputs, k))
    state = fmu.slave.getFMUstate()
    u = {"exact_z": 0.0, "z_ref": 1.0, "exact_z_dot": 0.0}
    first = [fmu.step((50 + j) * cls.period, cls.period, u) for j in range(20)]
    fmu.slave.setFMUstate(state)
    again = [fmu.step((50 + j) * cls.period, cls.period, u) for j in range(20)]
    assert first == again and first[0] != first[-1]  # the integral grows: the state matters, and came back


@pytest.mark.parametrize("fmi", ["2", "3"])
def test_the_fmu_validates_and_names_the_numbers_it_kept(tmp_path, fmi):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    fmu = _wrapped(HOVER, tmp_path / f"hover_{fmi}.fmu", "--fmi", fmi)
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    params = {v.name for v in md.modelVariables if v.causality == "parameter"}
    # the declared parameter, then the numbers __init__ kept (K is derived from position_scale: an expression of it)
    assert {"position_scale", "x_eq_0", "u_max_3"} <= params and "K_0_0" not in params
    assert md.fmiVersion.startswith(fmi)


UNTRACEABLE = {  # what needs the number while tracing (float(), math.* and np.clip trace: tests/app/test_plain_numpy.py)
    "an if on a value": ("        if e > 0:\n            e = -e\n", "a Python decision on a traced value"),
    "a while on a value": ("        while e > 1.0:\n            e = e / 2\n", "a Python decision on a traced value"),
    "min()": ("        e = min(e, 1.0)\n", "a Python decision on a traced value"),
    "math.isnan": ("        e = 0.0 if math.isnan(e) else e\n", "a traced value turned into a number"),
}


@pytest.mark.parametrize("what", UNTRACEABLE)
def test_what_cannot_be_traced_is_one_line_naming_its_line(tmp_path, capsys, what):
    code, said = UNTRACEABLE[what]
    source = tmp_path / "bad.py"
    source.write_text("import math\n\n\nclass Bad:\n    inputs = ['exact_z', 'z_ref']\n\n"
                      "    def step(self, t, inputs):\n        e = inputs['z_ref'] - inputs['exact_z']\n" + code
                      + "        return [10.0 + e, 10.0 + e, 0.0, 0.0]\n")
    line = 9  # the first line of the operation
    assert main(["wrap", "--native", str(source), "--out", str(tmp_path / "bad.fmu")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"Bad.step cannot be traced at line {line} (`{code.splitlines()[0].strip()}`)" in err[0]
    assert said in err[0] and not (tmp_path / "bad.fmu").exists()
    assert "decision" not in said or "np.where(condition, a, b)" in err[0]  # the numpy way to write the choice


@pytest.mark.slow
def test_a_declared_parameter_set_on_the_native_fmu_changes_the_run_as_on_the_pythonfmu_fmu(tmp_path, fmus):
    """--set controller.position_scale=1.3 (what the command line's --set does: thesis.set_parameters): the native
    FMU, where the gain is recomputed from the parameter in C, and the pythonfmu FMU, where __init__ runs in Python
    with it, give the same metrics; and they are not the defaults' (the parameter reached the gain)."""
    from tiltload.master.app.loop.thesis import default_system, loop_metrics, set_parameters
    from tiltload.master.engine.run import run_system

    native = _wrapped(HOVER, tmp_path / "hover_native.fmu")
    python = tmp_path / "hover_python.fmu"
    assert main(["wrap", str(HOVER), "--out", str(python)]) == 0

    def metrics(fmu: Path, scale: float | None) -> dict[str, float]:
        system = default_system(fmus, "fsi", 1, None, 1, fmu)
        if scale is not None:
            set_parameters(system, {"controller.position_scale": scale})
        result = run_system(system, 3.0, None, loop_metrics(), progress=False)
        assert result.error is None, result.error
        return result.metrics

    mine, theirs, default = metrics(native, 1.3), metrics(python, 1.3), metrics(native, None)
    keys = [k for k in mine if k.startswith("ISE(")]
    assert keys and all(abs(mine[k] - theirs[k]) <= 1e-12 * abs(theirs[k]) for k in keys), \
        {k: (mine[k], theirs[k]) for k in keys}
    assert all(abs(mine[k] - default[k]) > 1e-6 * abs(default[k]) for k in ("ISE(x)", "ISE(z)"))


@pytest.mark.slow
def test_in_the_closed_loop_every_platform_equals_linux_and_the_python_class(tmp_path, fmus):
    """The traced hover LQR (binaries for linux64, win64, aarch64) with the loop's FMUs, 5 s of trajectory 1 (fsi), in
    the portable C host on each platform: the ISE equals tiltload's own run on Linux (1e-12); and tiltload's run of
    the same class wrapped as Python (pythonfmu) gives the same ISE to 1e-9."""
    from support.portable import AARCH64, LINUX64, WIN64, Host, compile_host, loop_plan, need_platform, unpack, wine_environment
    from tiltload.master.app.loop.thesis import CONTROLLER, default_system, loop_metrics
    from tiltload.master.engine.run import run_system

    native = _wrapped(HOVER, tmp_path / "hover_native.fmu")
    python = tmp_path / "hover_python.fmu"
    assert main(["wrap", str(HOVER), "--out", str(python)]) == 0
    system = default_system(fmus, "fsi", 1, None, 1, native)
    seconds = 5.0
    ours = run_system(system, seconds, None, loop_metrics(), progress=False)
    assert ours.error is None
    as_python = run_system(default_system(fmus, "fsi", 1, None, 1, python), seconds, None, loop_metrics(), progress=False)
    assert as_python.error is None, as_python.error
    for axis in ("x", "y", "z", "psi"):
        key = f"ISE({axis})"
        assert abs(as_python.metrics[key] - ours.metrics[key]) <= 1e-9 * ours.metrics[key], key
    folders = {i.name: unpack(i.fmu, tmp_path / "unpacked") for i in system.instances}
    sources = folders["plant"] / "sources"
    for platform in (LINUX64, WIN64, AARCH64):
        need_platform(platform)
        binary = folders[CONTROLLER] / "binaries" / platform.folder
        assert any(binary.iterdir()), f"no {platform.folder} binary in the traced FMU"
        (tmp_path / platform.folder).mkdir()
        env = wine_environment(tmp_path / "wine") if platform is WIN64 else None
        host = Host(platform, compile_host(platform, sources, tmp_path / platform.folder), env)
        plan, tracked = loop_plan(system, folders, platform, tmp_path / platform.folder, seconds, every=25)
        run = host.run(plan)
        for axis, vr in tracked.items():
            assert abs(run.ise["plant", vr] - ours.metrics[f"ISE({axis})"]) <= 1e-12 * ours.metrics[f"ISE({axis})"], \
                (platform.folder, axis)
    if shutil.which("wineserver"):
        subprocess.run(["wineserver", "-k"], env=wine_environment(tmp_path / "wine"), capture_output=True, timeout=60)


def test_a_parameter_init_needs_the_number_of_is_refused_when_set_on_the_native_fmu(tmp_path, capfd):
    """hover_lqr.py's position_weight feeds a Riccati solver: fixed in the native FMU (wrap says so); set to another
    value, the FMU's initialization fails with a line naming it, and at its default it runs."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    fmu = _wrapped(ROOT / "docs" / "examples" / "hover_lqr.py", tmp_path / "hover.fmu")
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    said = []

    def instance(weight: float):
        slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu), str(tmp_path / str(weight))),
                          modelIdentifier=md.coSimulation.modelIdentifier, instanceName="c",
                          fmiCallLogger=None)
        slave.instantiate(loggingOn=True, callbacks=None)
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.setReal([vr["position_weight"]], [weight])
        try:
            slave.exitInitializationMode()
            return True
        except Exception as err:  # FMPy raises on fmi2Error
            said.append(str(err))
            return False
        finally:
            slave.freeInstance()
    assert instance(10.0) and not instance(3.0) and said
    assert "parameter position_weight is fixed at 10 in this native FMU" in capfd.readouterr().out  # FMPy prints the log


CORPUS = ROOT / "tests" / "support" / "data" / "plain_numpy_corpus.py"


@pytest.mark.slow
def test_the_corpus_native_fmus_on_every_platform_equal_linux(tmp_path, fmus):
    """Each class of the plain-numpy corpus (issue 65: 24) wrapped natively, 3 s of trajectory 1 (fsi) in the portable
    C host on win64 (wine) and aarch64 (qemu-user): the ISE of x, y, z, psi equals tiltload's own run on Linux
    (1e-12)."""
    from support.portable import AARCH64, WIN64, Host, compile_host, loop_plan, need_platform, unpack, wine_environment
    from tiltload.master.app.loop.thesis import default_system, loop_metrics
    from tiltload.master.app.wrap.wrap import load_module
    from tiltload.master.engine.run import run_system

    seconds, hosts = 3.0, {}
    names = [cls.__name__ for cls in load_module(CORPUS).CORPUS]
    assert len(names) == 24
    for name in names:
        native = _wrapped(CORPUS, tmp_path / f"{name}.fmu", "--class", name)
        system = default_system(fmus, "fsi", 1, None, 1, native)
        ours = run_system(system, seconds, None, loop_metrics(), progress=False)
        assert ours.error is None, (name, ours.error)
        folders = {i.name: unpack(i.fmu, tmp_path / name / "unpacked") for i in system.instances}
        for platform in (WIN64, AARCH64):
            need_platform(platform)
            where = tmp_path / name / platform.folder
            where.mkdir(parents=True)
            if platform.folder not in hosts:  # the host and the plant's sources are the same for every controller
                env = wine_environment(tmp_path / "wine") if platform is WIN64 else None
                (tmp_path / platform.folder).mkdir()
                hosts[platform.folder] = Host(platform, compile_host(platform, folders["plant"] / "sources",
                                                                     tmp_path / platform.folder), env)
            plan, tracked = loop_plan(system, folders, platform, where, seconds, every=25)
            run = hosts[platform.folder].run(plan)
            for axis, vr in tracked.items():
                assert abs(run.ise["plant", vr] - ours.metrics[f"ISE({axis})"]) <= 1e-12 * ours.metrics[f"ISE({axis})"], \
                    (name, platform.folder, axis)
    if shutil.which("wineserver"):
        subprocess.run(["wineserver", "-k"], env=wine_environment(tmp_path / "wine"), capture_output=True, timeout=60)
