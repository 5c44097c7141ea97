"""The twelve reproduction cases with the controller on `tiltload serve` (in a network namespace of its own when this
machine allows one, else on loopback in a process tree of its own): the in-process metrics, bit for bit."""

from __future__ import annotations

import pytest
from support import ROOT
from support.remote import Namespace, ServerProcess, netns_available, token_file
from tiltload.master.app.loop import default_stop, default_system, loop_metrics
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


def metrics(fmus, scenario, trajectory, controller, remote=None, token=None) -> dict:
    system = default_system(fmus, scenario, trajectory, controller, reproduce.SEED)
    ctrl = system.instance("controller")
    ctrl.remote, ctrl.token_file = remote, token
    result = run_system(system, default_stop(trajectory), None, loop_metrics(), progress=False)
    assert result.error is None, result.error
    return result.metrics


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
