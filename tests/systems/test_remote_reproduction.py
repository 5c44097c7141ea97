"""The twelve reproduction cases with the controller on `tiltload serve` (in a network namespace of its own when this
machine allows one, else on loopback in a process tree of its own): the in-process metrics, bit for bit; and the
clocked FMI 3.0 controller on loopback, the same."""

from __future__ import annotations

import pytest
from support import ROOT
from support.remote import Namespace, ServerProcess, netns_available, token_file
from tiltload.master.app.loop.thesis import default_stop, default_system, loop_metrics
from tiltload.master.app.regression import reproduce
from tiltload.master.engine.run import run_system


@pytest.fixture(scope="module")
def served(fmus, tmp_path_factory):
    token = token_file(tmp_path_factory.mktemp("secret"))
    space = Namespace() if netns_available() else None
    srv = ServerProcess(fmus, token, bind=f"{space.server_ip}:0" if space else "127.0.0.1:0",
                        netns=space.name if space else None)
    yield srv, token
    srv.stop()
    if space is not None:
        space.remove()


def metrics(fmus, scenario, trajectory, controller, remote=None, token=None, **fmi) -> dict:
    """The case's metrics; fmi: default_system's fmi and clocked (the FMI 3.0 loop, fmus its folder)."""
    system = default_system(fmus, scenario, trajectory, controller, reproduce.SEED, **fmi)
    ctrl = system.instance("controller")
    ctrl.remote, ctrl.token_file = remote, token
    result = run_system(system, default_stop(trajectory), None, loop_metrics(), progress=False)
    assert result.error is None, result.error
    return result.metrics


@pytest.mark.slow
def test_the_twelve_cases_with_a_remote_controller_give_the_in_process_metrics_bit_for_bit(fmus, served):
    srv, token = served
    results = []
    for scenario, trajectory, controller in reproduce.CASES:
        local = metrics(fmus, scenario, trajectory, controller)
        remote = metrics(fmus, scenario, trajectory, controller, srv.address, token)
        name = reproduce.case_name(scenario, trajectory, controller)
        assert remote == local, name  # every metric, to the last bit
        results.append({"case": name, "metrics": remote})
    assert reproduce.check_baselines(results, ROOT / "baselines")  # and they are the committed results
    assert srv.count("session ended (controller: exit 0)", len(reproduce.CASES)) == len(reproduce.CASES)


@pytest.fixture(scope="module")
def served_fmi3(fmus, tmp_path_factory):
    """The clocked FMI 3.0 loop's FMUs (fmus/fmi3/), served on loopback."""
    from tiltload.master.app.loop.fmus import build_all, fmu_folder

    folder = fmu_folder(fmus, 3)
    build_all(folder, progress=lambda *_: None, fmi_version=3, clocked=True)
    token = token_file(tmp_path_factory.mktemp("secret3"))
    srv = ServerProcess(folder, token)
    yield folder, srv, token
    srv.stop()


@pytest.mark.slow
def test_the_twelve_cases_with_a_remote_clocked_fmi3_controller_give_the_in_process_metrics_bit_for_bit(served_fmi3):
    """The clocked controller's Event Mode, clock activation and discrete-state update run in the server's worker, one
    round trip per step: the same metrics as in process, and as the committed (FMI 2.0) baselines."""
    folder, srv, token = served_fmi3
    results = []
    for scenario, trajectory, controller in reproduce.CASES:
        case = {"fmi": 3, "clocked": True}
        local = metrics(folder, scenario, trajectory, controller, **case)
        remote = metrics(folder, scenario, trajectory, controller, srv.address, token, **case)
        name = reproduce.case_name(scenario, trajectory, controller)
        assert remote == local, name
        results.append({"case": name, "metrics": remote})
    assert reproduce.check_baselines(results, ROOT / "baselines")
    assert srv.count("session ended (controller: exit 0)", len(reproduce.CASES)) == len(reproduce.CASES)
