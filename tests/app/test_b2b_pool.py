"""b2b's runs go through one execution pool: the FMUs are loaded once for all cases and sides, and a restarted run
logs what a fresh run of the same case logs, bit for bit."""

from __future__ import annotations

import numpy as np
from tiltload.master.app.regression.back_to_back import SIGNALS, Case, Side, back_to_back, run_side
from tiltload.master.engine.lifecycle import ExecutionPool
from tiltload.master.engine.log.reader import read_columns


def test_the_cases_restart_one_execution_and_log_what_a_fresh_run_logs(fmus, tmp_path):
    cases = [Case("lkf", 1, "dlqr", stop_time=0.3), Case("zse", 2, "mixed", stop_time=0.3)]
    pool = ExecutionPool()
    try:
        result = back_to_back(cases, Side(fmus), Side(fmus, settings=(("controller.x_0", 1.75),)), tmp_path / "b2b",
                              echo=lambda line: None, pool=pool)
    finally:
        pool.close()
    assert pool.instantiated == 1  # four runs, one structure: loaded once, restarted three times
    assert not result.results[0].ok and result.results[1].ok  # x_0 is the LKF's; the ZSE does not read it
    fresh, _, _ = run_side(cases[1], Side(fmus), tmp_path / "fresh.mcap", None)
    restarted, _ = read_columns(tmp_path / "b2b" / "zse_traj2_mixed_reference.mcap")
    alone, _ = read_columns(fresh)
    for name in SIGNALS:
        topic, variable = "/" + name.split(".")[0], name.split(".")[1]
        np.testing.assert_array_equal(restarted[topic][0], alone[topic][0])
        np.testing.assert_array_equal(restarted[topic][1][variable], alone[topic][1][variable])
