"""The packaging's target list: one FMI 3.0 FMU with binaries for x86_64-linux and, with the cross compiler, for
aarch64-linux; the aarch64 binaries run the clocked sensors and the scenario in the C host under qemu-user and agree
with x86_64's (bit for bit is the platforms work's: FP contraction pinned in the sources)."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from fmpy.validation import validate_fmu
from support import HOSTS, T
from support.fmi3_plan import host_plan
from tiltload.master.engine.system import Instance, System
from tiltload.native_fmu.build import build
from tiltload.native_fmu.compile import Target, native_target
from tiltload.native_fmu.package import fmi_header_dir
from tiltload.scenario_fmu import build as scenario
from tiltload.sensor_fmu import build as sensors
from tiltload.sensor_fmu.fmu_variables import channel_names
from tiltload.sensor_fmu.suite import GROUPS

CROSS, QEMU, SYSROOT = "aarch64-linux-gnu-gcc", "qemu-aarch64", "/usr/aarch64-linux-gnu"
pytestmark = pytest.mark.skipif(not (shutil.which(CROSS) and shutil.which(QEMU)), reason="no aarch64 cross compiler or qemu-user")


def _values(proc) -> np.ndarray:
    assert proc.returncode == 0, proc.stdout[-1000:] + proc.stderr[-2000:]
    return np.array([float.fromhex(line.split()[3]) for line in proc.stdout.splitlines() if line.split()[0].isdigit()])


def test_a_target_list_builds_aarch64_binaries_that_run_under_qemu(tmp_path):
    targets = (native_target(), Target("aarch64-linux", None, CROSS))
    fmus = {r.fmu_name: build(r, tmp_path / "fmus", progress=lambda *_: None, fmi_version=3, targets=targets).path
            for r in (scenario.recipe(), sensors.recipe("load", clocked=True))}
    for fmu in fmus.values():
        assert validate_fmu(str(fmu)) == []
    with pytest.raises(Exception, match="FMI 2.0 has no platform folder for aarch64-linux"):
        build(scenario.recipe(), tmp_path / "fmi2", progress=lambda *_: None, targets=targets)
    system = System(T, [Instance("scenario", fmus["TiltloadScenario.fmu"], parameters={"trajectory": 2}),
                        Instance("sensors", fmus["TiltloadSensorsClocked.fmu"], parameters={"seed": 5})], auto_connect=False)
    record = [("scenario", "x_ref"), ("scenario", "z_ref")] + [("sensors", n) for g in GROUPS for n in channel_names(g)]
    ticks = round(1.2 / T)
    runs = {}
    for platform, cc, prefix in (("x86_64-linux", "cc", []), ("aarch64-linux", CROSS, [QEMU, "-L", SYSROOT])):
        folder = tmp_path / platform
        folder.mkdir()
        plan = host_plan(system, folder, ticks, record, platform)
        host = folder / "host"
        subprocess.run([cc, "-std=c11", "-Wall", "-Wextra", "-Werror", f"-I{fmi_header_dir(3)}", str(HOSTS / "fmi3_loop_host.c"),
                        "-o", str(host), "-ldl", "-lm"], check=True)
        binary = folder / "sensors" / "binaries" / platform / "TiltloadSensors.so"
        kind = subprocess.run(["file", "-L", str(binary)], capture_output=True, text=True).stdout
        assert ("ARM aarch64" in kind) == (platform == "aarch64-linux"), kind
        runs[platform] = _values(subprocess.run([*prefix, str(host), str(plan)], capture_output=True, text=True, timeout=300))
    x86, arm = runs["x86_64-linux"], runs["aarch64-linux"]
    assert len(x86) == len(arm) == ticks * len(record) and np.isfinite(x86).all()
    np.testing.assert_allclose(arm, x86, rtol=1e-12, atol=1e-12)
