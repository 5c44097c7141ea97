"""The one run life cycle (engine/lifecycle.py): a pool restarts an execution of the same structure, instantiates one
for another structure, closes the execution after a run that ended fatally or outside its outcomes; a plan run again on
one pool gives the fresh run's metrics and log bytes; and no module of the life cycle keeps a mutable dict of its own."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from tiltload.master.app.loop.thesis import default_system, loop_metrics
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.lifecycle import ExecutionPool, RunPlan, run_plan
from tiltload.master.engine.observers import Observer

STOP = 0.6
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def calls(monkeypatch) -> dict[str, int]:
    """How often an execution was instantiated (FMUs loaded) and restarted (fmi2Reset), counted at the Execution."""
    counted = {"instantiate": 0, "restart": 0}
    for name in counted:
        original = getattr(Execution, name)

        def counting(self, *args, _name=name, _original=original, **kwargs):
            counted[_name] += 1
            return _original(self, *args, **kwargs)
        monkeypatch.setattr(Execution, name, counting)
    return counted


def _system(fmus, mass: float = 0.05, delay: bool = False):
    system = default_system(fmus, "zse", 1, "mixed", seed=2, delay=delay)
    system.instance("plant").parameters["m_L"] = mass
    return system


def test_the_pool_restarts_the_same_structure_and_instantiates_another(fmus, calls):
    pool = ExecutionPool()
    try:
        first = run_plan(RunPlan(_system(fmus), STOP, metrics=loop_metrics()), pool)
        second = run_plan(RunPlan(_system(fmus, mass=0.2), STOP, metrics=loop_metrics()), pool)
        assert calls == {"instantiate": 1, "restart": 1} and len(pool) == 1
        assert first.error is None and second.error is None and first.metrics != second.metrics  # the new mass was set
        run_plan(RunPlan(_system(fmus, delay=True), STOP, metrics=loop_metrics()), pool)  # a delay line: another structure
        assert calls == {"instantiate": 2, "restart": 1} and len(pool) == 2
        run_plan(RunPlan(_system(fmus, delay=True), STOP), pool)
        run_plan(RunPlan(_system(fmus), STOP), pool)
        assert calls == {"instantiate": 2, "restart": 3} and len(pool) == 2
    finally:
        pool.close()
    assert len(pool) == 0


class Fatal(Observer):
    """Marks the plant's instance as having reported fmi2Fatal (the flag a Fatal status sets) during the run."""

    def on_batch(self, execution, batch) -> None:
        execution.instances["plant"].fatal = True


class Broken(Observer):
    """Fails as a bug would, outside the run's outcomes."""

    def on_batch(self, execution, batch) -> None:
        raise RuntimeError("a bug in an observer")


def test_the_pool_closes_an_execution_after_a_fatal_run_and_after_a_failure_outside_the_outcomes(fmus, calls):
    pool = ExecutionPool()
    try:
        run_plan(RunPlan(_system(fmus), STOP, observers=(Fatal(),)), pool)
        assert len(pool) == 0  # not kept: no call is allowed after Fatal
        run_plan(RunPlan(_system(fmus), STOP), pool)
        assert calls == {"instantiate": 2, "restart": 0} and len(pool) == 1
        (kept,) = pool.executions()
        with pytest.raises(RuntimeError, match="a bug in an observer"):
            run_plan(RunPlan(_system(fmus), STOP, observers=(Broken(),), outcomes=()), pool)
        assert calls == {"instantiate": 2, "restart": 1} and len(pool) == 0 and kept.instances == {}  # closed
        result = run_plan(RunPlan(_system(fmus), STOP, observers=(Broken(),)), pool)  # the default: the run's outcome
        assert result.error.startswith("a bug in an observer") and isinstance(result.failure, RuntimeError)
        assert len(pool) == 1  # a failure that is the run's outcome keeps the execution
    finally:
        pool.close()


def test_a_plan_run_again_on_one_pool_gives_the_fresh_run_bit_for_bit(fmus, tmp_path):
    def plan(name: str, mass: float) -> RunPlan:
        return RunPlan(_system(fmus, mass), STOP, tmp_path / f"{name}.mcap", {"case": "lifecycle"}, metrics=loop_metrics())

    fresh = run_plan(plan("fresh", 0.2))  # no pool: an execution for this run only
    pool = ExecutionPool()
    try:
        run_plan(plan("before", 0.05), pool)  # another run on the execution first: its reset leaves nothing behind
        again = run_plan(plan("again", 0.2), pool)
        assert pool.instantiated == 1
    finally:
        pool.close()
    assert fresh.metrics and again.metrics.keys() == fresh.metrics.keys()
    assert all(again.metrics[k] == fresh.metrics[k] for k in fresh.metrics)  # floats, bit for bit
    assert (tmp_path / "again.mcap").read_bytes() == (tmp_path / "fresh.mcap").read_bytes()
    assert (tmp_path / "before.mcap").read_bytes() != (tmp_path / "fresh.mcap").read_bytes()


LIFE_CYCLE_MODULES = ["master/engine/lifecycle.py", "master/engine/run.py", "master/app/campaign/run_case.py",
                      "master/app/batch/worker.py", "master/app/case/system.py", "master/app/campaign/metrics.py",
                      "master/app/campaign/runner.py", "master/app/falsify/evaluate.py", "master/app/falsify/branching.py",
                      "master/app/falsify/runner.py", "master/app/regression/reproduce.py", "master/app/testing/plugin.py"]


def _module_dicts(path: Path) -> list[str]:
    """The names a module binds at its top level to a dict (a literal, a comprehension, dict(), defaultdict()...)."""
    found = []
    for node in ast.parse(path.read_text()).body:
        targets, value = ([node.target], node.value) if isinstance(node, ast.AnnAssign) else (
            (node.targets, node.value) if isinstance(node, ast.Assign) else ([], None))
        annotated = isinstance(node, ast.AnnAssign) and "dict" in ast.unparse(node.annotation).lower()
        made = isinstance(value, (ast.Dict, ast.DictComp)) or (
            isinstance(value, ast.Call) and ast.unparse(value.func).split(".")[-1] in ("dict", "defaultdict", "OrderedDict"))
        if annotated or made:
            found += [ast.unparse(t) for t in targets]
    return found


def test_the_scan_finds_a_module_level_dict(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text("A: dict[str, int] = {}\nB = dict()\nC = 3\ndef f():\n    d = {}\n")
    assert _module_dicts(sample) == ["A", "B"]


@pytest.mark.parametrize("module", LIFE_CYCLE_MODULES)
def test_no_module_of_the_life_cycle_keeps_a_dict_of_its_own(module):
    assert _module_dicts(ROOT / module) == []
