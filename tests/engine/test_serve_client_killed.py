"""`tiltload serve` after a client is killed: its place among the FMU's clients is given back when its connection
closes, not when its worker ends (a worker busy in the FMU is ended GRACE seconds later), so the next master that
asks right away is served (issue 62)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

from support.fmi2_session import wrap_misbehaving
from support.remote import ServerProcess, token_file
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.isolation.hosting import remote_fmu
from tiltload.master.engine.isolation.server import GRACE

CLIENT = """
import sys
from pathlib import Path
from tiltload.master.engine.fmi.model_description import read_fmu
from tiltload.master.engine.isolation.hosting import remote_fmu
fmu, address, token = map(Path, sys.argv[1:4])
inst = remote_fmu("controller", fmu, read_fmu(fmu, "controller"), str(address), token, timeout=3600)
inst.initialize({})
inst.do_step(0.0, 0.012)  # the first step hovers (wrap steps the class once at t = 0 before it writes an FMU)
print("stepping", flush=True)
inst.do_step(0.012, 0.012)  # the FMU sleeps an hour in this step
"""


def test_a_killed_client_frees_its_fmu_for_the_next_one_at_once(tmp_path):
    token = token_file(tmp_path)
    fmu = wrap_misbehaving(tmp_path, {"hang": "time.sleep(3600)"}, 0.012)["hang"]
    srv = ServerProcess(tmp_path, token)
    try:
        client = subprocess.Popen([sys.executable, "-c", CLIENT, str(fmu), srv.address, str(token)],
                                  stdout=subprocess.PIPE, text=True)
        assert client.stdout.readline().strip() == "stepping"
        srv.wait_for("serving bad_hang.fmu")
        time.sleep(0.5)  # its step request is with the worker, which sleeps in the FMU
        client.send_signal(signal.SIGKILL)
        client.wait()
        killed_at = time.monotonic()
        second = remote_fmu("controller", fmu, read_fmu(fmu, "controller"), srv.address, token)  # no "serving 1 client"
        asked_within = time.monotonic() - killed_at
        second.close()
        assert asked_within < GRACE, asked_within  # before the first worker could have been ended: the place was free
        assert "still busy (hung?): killed" in srv.wait_for("the client left")  # and the busy worker is ended all the same
        srv.wait_for("session ended")
    finally:
        srv.stop()
