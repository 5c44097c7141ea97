"""The shared-memory link to an isolated FMU's host (isolation/link.py, tl_link.h): the tick loop steps the FMU over
it, and a host that misbehaves on the segment (dies in the middle of a reply, announces more than its frame, names a
group or a clock the FMU does not have, answers a request it was not sent, never answers, answers without waking the
master) ends the run with one line naming the FMU, the call and the time, the master reading nothing outside the
segment."""

from __future__ import annotations

import sys
import textwrap

import pytest
from support.fmi2_session import foreign_copy
from tiltload.master.app.loop.fmus import is_foreign
from tiltload.master.app.loop.thesis import default_stop, default_system, loop_metrics
from tiltload.master.engine.errors import ExecutionError
from tiltload.master.engine.execution import Execution
from tiltload.master.engine.isolation import hosting, link, process

pytestmark = pytest.mark.skipif(not link.available(), reason="the shared-memory link is Linux's")

# A worker whose C loop on the segment is replaced, the second time the master takes the link, by one in Python that
# misbehaves at the first step as HOSTILE says (the steps before answered by the real loop). The master sees the segment.
HOSTILE = textwrap.dedent("""
    import os, signal, struct, sys, time
    from tiltload.master.engine.isolation import link

    MODE = os.environ["HOSTILE"]
    real = link.HostLink.serve

    taken = []

    def serve(self):
        m, h = self.map, self.host
        taken.append(1)
        if len(taken) == 1:
            return real(self)
        while True:
            while struct.unpack_from("<I", m, link.REQUEST)[0] == h.seq:
                time.sleep(0.0002)
            seq = struct.unpack_from("<I", m, link.REQUEST)[0]
            out = h.out_offset
            if MODE == "die":  # half the outputs written, then killed before the reply is published
                m[out + link.HEADER:out + link.HEADER + 16] = b"\\xff" * 16
                os.kill(os.getpid(), signal.SIGKILL)
            if MODE == "beyond":  # a reply announcing outputs far past its frame and the segment
                struct.pack_into("<iiiidqII", m, out, 0, 0, 0, 0, 0.0, 0, 1 << 31, 0)
                struct.pack_into("<I", m, link.REPLY, seq)
            if MODE == "group":  # a failed set naming a group the instance does not have
                struct.pack_into("<iiiidqII", m, out, 3, 1, 1 << 20, 0, 0.0, 0, self.expected, 0)
                struct.pack_into("<I", m, link.REPLY, seq)
            if MODE == "clock":  # a failure of a clocked FMU's sequence naming a clock this FMU does not have
                struct.pack_into("<iiiidqIIii", m, out, 3, 4, 7, 0, 0.0, 0, self.expected, 0, 13, 0)
                struct.pack_into("<I", m, link.REPLY, seq)
            if MODE == "sequence":  # an answer to a request that was never sent
                struct.pack_into("<I", m, link.REPLY, seq + 7)
            time.sleep(3600)  # "silent": never answers, never wakes the master

    def expected(self):
        return sum(link.WIDTH[t] * n for t, n in zip(link.TYPES, self.host.n_out))

    link.HostLink.serve = serve
    link.HostLink.expected = property(expected)
    from tiltload.master.command_line.worker import main
    main()
""")

EXPECTED = {
    "die": "the FMU crashed (SIGKILL) in doStep at t=0.096 s",
    "beyond": "doStep at t=0.096 s: its host sent a corrupt reply on shared memory (outputs of another length than the model's",
    "group": "doStep at t=0.096 s: its host sent a corrupt reply on shared memory (an unknown call or status",
    "clock": "doStep at t=0.096 s: its host sent a corrupt reply on shared memory (an unknown call or status",
    "sequence": "doStep at t=0.096 s: its host sent a corrupt reply on shared memory (a sequence number it was not asked for",
    "silent": "doStep at t=0.096 s did not return within 1 s (watchdog",
}


@pytest.fixture(scope="module")
def foreign(fmus, tmp_path_factory):
    return foreign_copy(fmus / "TiltloadController.fmu", tmp_path_factory.mktemp("link") / "Foreign.fmu")


def _execution(fmus, foreign, timeout=1.0) -> Execution:
    system = default_system(fmus, "lkf", 1, "mixed")
    system.instances[2].fmu = foreign
    ex = Execution(system, [loop_metrics()], isolate=is_foreign, step_timeout=timeout)
    ex.instantiate()
    return ex


@pytest.mark.parametrize("mode", list(EXPECTED))
def test_a_host_misbehaving_on_the_segment_ends_the_run_with_one_line(mode, fmus, foreign, tmp_path, monkeypatch):
    script = tmp_path / "hostile_worker.py"
    script.write_text(HOSTILE)
    monkeypatch.setenv("HOSTILE", mode)
    monkeypatch.setattr(process, "WORKER_COMMAND", (sys.executable, str(script)))
    ex = _execution(fmus, foreign)
    controller = ex.instances["controller"]
    proc = controller.host.proc
    try:
        ex.run(0.1)  # ticks 0 ... 7 by the real loop
        controller.set_values({})  # a request on the pipe: the host yields the segment, and takes it again for tick 8
        with pytest.raises(ExecutionError) as failure:
            ex.run(1.0)
        assert ex.loop.paths["controller"] == "kernel: shared memory (worker process)"
        line = str(failure.value)
        assert line.startswith("controller: ") and EXPECTED[mode] in line and "\n" not in line, line
        assert ex.ticks_done == 8  # the ticks before the strike ran (t = 0 ... 0.084 s), their outputs kept
        assert controller.fatal
    finally:
        ex.close()
    assert proc.poll() is not None  # the host is gone, killed if it had to be


def test_a_snapshot_and_a_reset_of_a_linked_fmu_continue_as_in_process(fmus, foreign):
    """get_state and reset go back to the pipe (the host yields the segment) and the steps after them to the segment
    again, with the results of the pipe's path (test_snapshot.py continues a linked FMU from a snapshot)."""
    tables = {}
    for shared in (False, True):
        hosting_was = hosting.SHARED_MEMORY
        hosting.SHARED_MEMORY = shared
        try:
            ex = _execution(fmus, foreign, timeout=10.0)
        finally:
            hosting.SHARED_MEMORY = hosting_was
        try:
            ex.run(0.6)
            state = ex.instances["controller"].get_state()  # the host yields the segment for it, and takes it again
            ex.run(1.2)
            assert len(state) > 0
            tables[shared] = (ex.observers[0].table(), ex.instances["plant"].values["Real"].copy())
            ex.restart()
            ex.run(0.3)
            tables[shared] += (ex.observers[0].table(),)
            assert ex.loop.paths["controller"] == ("kernel: shared memory (worker process)" if shared else "callback: worker process")
        finally:
            ex.close()
    assert tables[True][0] == tables[False][0]
    assert (tables[True][1] == tables[False][1]).all()
    assert tables[True][2] == tables[False][2]


def test_the_twelve_reproduction_cases_through_the_link_give_the_in_process_metrics_bit_for_bit(fmus):
    """The shipped controller forced into a worker process (stepped over shared memory) in every case of `tiltload
    reproduce`, each its whole length: every metric equal to the last bit to the run in process."""
    from tiltload.master.app.regression.reproduce import CASES, SEED
    from tiltload.master.engine.lifecycle import RunPlan, run_plan

    def controller_only(fmu, md):
        return "Controller" in fmu.name

    for scenario, trajectory, controller in CASES:
        results = []
        for isolate in (None, controller_only):
            system = default_system(fmus, scenario, trajectory, controller, SEED)
            results.append(run_plan(RunPlan(system, default_stop(trajectory), metrics=loop_metrics(), isolate=isolate,
                                            profile=isolate is not None)))
        here, linked = results
        assert here.error is None and linked.error is None, (scenario, trajectory, controller, linked.error)
        assert next(f for f in linked.profile.fmus if f.name == "controller").isolated == "shared memory"  # not the pipe
        assert here.ticks == linked.ticks and here.metrics == linked.metrics, (scenario, trajectory, controller)


def test_ctrl_c_stops_a_wait_on_the_link_at_once(fmus, foreign, tmp_path, monkeypatch):
    """A host that never answers and a watchdog of 60 s: SIGINT one second into the wait ends it as KeyboardInterrupt
    (not after the watchdog), the host killed."""
    import os
    import signal
    import threading
    import time

    script = tmp_path / "hostile_worker.py"
    script.write_text(HOSTILE)
    monkeypatch.setenv("HOSTILE", "silent")
    monkeypatch.setattr(process, "WORKER_COMMAND", (sys.executable, str(script)))
    ex = _execution(fmus, foreign, timeout=60.0)
    controller = ex.instances["controller"]
    proc = controller.host.proc
    try:
        ex.run(0.1)
        controller.set_values({})
        timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT))
        started = time.monotonic()
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            ex.run(1.0)
        assert time.monotonic() - started < 20
        assert controller.fatal and ex.ticks_done == 8
    finally:
        ex.close()
    assert proc.poll() is not None
    assert signal.set_wakeup_fd(-1) == -1  # the wakeup fd given back


SPIN_RULES = r"""
#define _DEFAULT_SOURCE /* syscall(SYS_futex), as the loop and the host have it */
#include <assert.h>
#include <stdint.h>
#include <stdio.h>
#include "tl_link.h"

int main(void) {
    /* the wait lasts from start (100) to now (300); the other side says when it sent */
    assert(tl_link_waited(100, 250, 300) == 150);
    assert(tl_link_waited(100, 50, 300) == 0);          /* sent before the wait began: nothing waited */
    assert(tl_link_waited(100, INT64_MAX, 300) == 200); /* a time to come: the whole wait, no more */
    assert(tl_link_waited(100, INT64_MIN, 300) == 0);
    /* a wait that slept 300 us on the futex for an answer sent after 20 us teaches 20 us, not 300 */
    int64_t usual = 20000;
    for (int i = 0; i < 100; i++) usual = tl_spin_learn(usual, tl_link_waited(0, 20000, 300000));
    assert(usual == 20000);
    /* an answer usually within half the longest spin: the longest spin; one usually slower: the base, then sleep */
    assert(tl_spin_budget(30000, usual) == TL_LINK_SPIN_MAX_NS);
    assert(tl_spin_budget(30000, TL_LINK_SPIN_MAX_NS / 2 + 1) == 30000);
    puts("ok");
    return 0;
}
"""


def test_a_wait_learns_when_the_other_side_answered_not_when_it_woke(tmp_path):
    """tl_link.h's spin rules: the time a wait learns is until the other process sent its answer (its clock reading,
    kept within the wait whatever it wrote), so one futex wake-up (100 µs and more on a VM) does not teach a long usual
    wait that makes every next wait sleep too; a side whose answers usually come within half the longest spin spins
    that long."""
    import subprocess

    from tiltload.master.engine.native import kernel

    source = tmp_path / "spin_rules.c"
    source.write_text(SPIN_RULES)
    program = tmp_path / "spin_rules"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", f"-I{kernel.HERE}", str(source), "-o", str(program)],
                   check=True)
    assert subprocess.run([str(program)], capture_output=True, text=True).stdout == "ok\n"
