"""Model-in-the-loop: the thesis's controller as its numpy reference implementation (controller_fmu/reference/runtime.py,
the oracle the C is tested against), in the loop with the ports of the controller FMU (docs/mil_sil_pil.md).

`ReferenceController` is a slave (engine/fmi/slave.py) with the FMU's model description whose tick is ControllerRuntime's
step, in Python. It is served over tiltload's remote protocol by a process of its own (`python -m
tiltload.master.app.regression.mil --fmu F --token-file T`, the worker's request loop with this slave as its loader),
so that the master runs it as the remote controller of an unchanged run, as it runs the C build (SIL) in process and
the aarch64 build (PIL) on tl_serve under qemu: the three differ only in where and as what the controller runs.
"""

from __future__ import annotations

import argparse
import contextlib
import secrets
import socket
import subprocess
import sys
import tempfile
from functools import cache
from pathlib import Path

import numpy as np

from ...engine.errors import DescriptionError, ExecutionError
from ...engine.fmi.slave import TYPES, Slave
from .pil import START_TIMEOUT, Served

TICK = 0.012
REF = ("x_ref", "y_ref", "z_ref", "vx_ref", "vy_ref", "vz_ref", "ax_ref", "ay_ref", "az_ref", "psi_ref", "psi_dot_ref")


@cache
def _design(tc: float) -> tuple[dict, object]:
    """The build-time bundle (gains, estimator matrices) and the feedforward bound to the model's parameters."""
    from ....controller_fmu.design import feedforward as ff
    from ....controller_fmu.fmu.build import bundle

    b = bundle(tc, progress=lambda *_: None)
    return b, ff.bound(b["params"])


class ReferenceController(Slave):
    """The controller FMU's ports, its tick computed by the numpy reference: u = sat(u_tr - K chi) after the estimator.
    Inputs are kept as the setters give them; doStep(t) runs one tick on those at t, as the C FMU does. gain (i, j,
    factor): the gain's entry K[i, j] multiplied by factor (a deliberately broken candidate; None: the design's)."""

    def __init__(self, name: str, path, md, tick: float | None = None, gain: tuple[int, int, float] | None = None) -> None:
        from ....plant_fmu.interface import STATE_NAMES
        from ....sensor_fmu.suite import GROUPS, ZSE_NAMES

        super().__init__(name, path, md)
        self.values = {t: np.zeros(len(vs), dtype=np.float64 if t == "Real" else np.int32) for t, vs in self.outputs.items()}
        inputs = [v for v in md.modelVariables if v.causality == "input"]
        self._slot = {(v.type, v.valueReference): i for i, v in enumerate(inputs)}
        self._start = np.array([float(v.start) if v.type == "Real" else float(v.start in ("true", True, "1", 1))
                                for v in inputs])
        self._inputs = self._start.copy()
        index = {v.name: i for i, v in enumerate(inputs)}
        self._ref = [index[n] for n in REF]
        self._exact = [index[f"exact_{n}"] for n in STATE_NAMES]
        self._lkf = [index[f"lkf_{n}"] for n in STATE_NAMES[:10]]
        self._meas = [index[f"meas_{n}"] for n in ZSE_NAMES]
        groups = [g for g in GROUPS if g.source == "pi"]
        self._flags = [(index[f"{g.name}_new"], list(g.indices)) for g in groups]
        self._parameters = {v.name: v.start for v in md.modelVariables if v.causality == "parameter"}
        self._set: dict[str, object] = {}
        self._out = {v.name: (t, i) for t, vs in self.outputs.items() for i, v in enumerate(vs)}
        extended = [*STATE_NAMES, "d_x", "d_y", "d_z"]
        self._est = [self._out[f"est_{n}"][1] for n in extended]
        self._lo = [self._out[f"est_{n}_lo"][1] for n in extended]
        self._hi = [self._out[f"est_{n}_hi"][1] for n in extended]
        self._u = [self._out[n][1] for n in ("f_R", "f_L", "tau_R", "tau_L")]
        self.setters = {t: self._setter(t) for t in TYPES}
        self.runtime = None
        self.gain = gain

    def _setter(self, typ: str):
        def setter(component, vrs, n, buf):
            for k in range(n):
                slot = self._slot.get((typ, vrs[k]))
                if slot is None:
                    return 3  # fmi2Error: not an input
                self._inputs[slot] = float(buf[k])
            return 0
        return setter

    def _publish(self) -> None:
        rt, real = self.runtime, self.values["Real"]
        real[self._u] = rt.sent[0]
        real[self._est] = np.r_[rt.estimate, rt.disturbance]
        if rt.k:  # before the first tick the C publishes the trim with bounds of zero width
            real[self._lo], real[self._hi] = rt.lower, rt.upper
        else:
            real[self._lo] = real[self._hi] = real[self._est]
        if rt.estimator == "zse" and rt.k:
            real[self._out["zse_G_frobenius"][1]] = rt.frobenius
            real[self._out["zse_generators"][1]] = rt.generators
        self.values["Integer"][self._out["skipped_measurements"][1]] = len(rt.flags) if rt.k else 0

    def initialize(self, parameters: dict) -> None:
        from ....controller_fmu.reference.runtime import ControllerRuntime, SetupError

        p = {**self._parameters, **self._set, **parameters}
        tc = float(p["Tc"])
        design, feedforward = _design(tc)
        try:
            self.runtime = ControllerRuntime(design, str(p["controller"]), str(p["estimator"]), feedforward,
                                             (float(p["f_min"]), float(p["f_max"]), float(p["tau_max"])),
                                             np.array([float(p[a]) for a in ("x_0", "y_0", "z_0")]), str(p["zse_reduction"]),
                                             int(p["loop_delay_ticks"]))
        except SetupError as err:
            raise ExecutionError(f"{self.name}: invalid controller parameters: {err}") from None
        if self.gain is not None:
            i, j, factor = self.gain
            K = self.runtime.law.K.copy()
            K[i, j] *= factor
            self.runtime.law.K = K
        for v in self.values.values():
            v[:] = 0
        self._publish()

    def reset(self) -> None:
        self.runtime, self._set = None, {}
        self._inputs = self._start.copy()

    def do_step(self, t: float, h: float) -> None:
        x = self._inputs
        available = np.zeros(len(self._meas), dtype=bool)
        for flag, channels in self._flags:
            available[channels] = x[flag] != 0
        u = self.runtime.step(x[self._ref], x[self._exact], x[self._lkf], x[self._meas], available)
        if not np.isfinite(u).all():
            raise ExecutionError(f"{self.name}: the reference controller produced a non-finite input at t={t:.6g} s")
        self._publish()

    def read_outputs(self) -> None:
        """The outputs are published by each step."""

    def set_values(self, values: dict) -> None:
        self._set.update(values)

    @property
    def can_serialize(self) -> bool:
        return False

    def get_state(self) -> bytes:
        raise ExecutionError(f"{self.name}: the Python reference controller has no FMU state")

    def set_state(self, state: bytes) -> None:
        raise ExecutionError(f"{self.name}: the Python reference controller has no FMU state")

    def close(self) -> None:
        self.runtime = None


def serve(fmu: Path, secret: bytes, sock: socket.socket, say, gain: tuple[int, int, float] | None = None) -> None:
    """Sessions one after the other: the handshake, the request for the controller, the worker's loop."""
    from ...engine.fmi.model_description import read_fmu
    from ...engine.isolation import handshake, wire
    from ...engine.isolation.transport import Channel, LinkClosed, LinkTimeout
    from ...engine.isolation.worker import serve as serve_requests

    md = read_fmu(fmu, "controller")
    while True:
        conn, _ = sock.accept()
        try:
            handshake.server_side(conn, secret, START_TIMEOUT)
            channel = Channel.over_socket(conn)
            request = wire.decode_control(channel.receive(START_TIMEOUT, handshake.OPEN_LIMIT))
            if (request.get("model_identifier"), request.get("guid")) != (md.coSimulation.modelIdentifier, md.guid):
                channel.send(wire.error("refused", f"this server runs the reference of {md.coSimulation.modelIdentifier} only",
                                        False, []))
                continue
            channel.send(wire.control({"ok": True, "fmu": Path(fmu).name, "log": []}))
            serve_requests(str(fmu), str(request.get("instance", "controller")), channel, None, say,
                           loader=lambda name, path, md, tick=None: ReferenceController(name, path, md, tick, gain))
        except (handshake.HandshakeFailed, LinkClosed, LinkTimeout, wire.ProtocolError) as err:
            say(f"session ended: {err}")
        finally:
            conn.close()


@contextlib.contextmanager
def served(fmu: Path, gain: tuple[int, int, float] | None = None):
    """The reference controller (gain: one entry of K scaled, see ReferenceController) served by a Python process of its
    own while the block runs: its address and token."""
    with tempfile.TemporaryDirectory(prefix="tl_mil_") as tmp:
        token = Path(tmp) / "token"
        token.write_text(secrets.token_hex(32))
        token.chmod(0o600)
        with open(Path(tmp) / "stderr", "wb") as err:
            proc = subprocess.Popen([sys.executable, "-m", __name__, "--fmu", str(Path(fmu).resolve()), "--token-file", str(token),
                                     *(["--scale-gain", ",".join(map(repr, gain))] if gain else [])],
                                    stdout=subprocess.PIPE, stderr=err, text=True)
        try:
            from .pil import first_line

            line = first_line(proc)
            if not line.startswith("listening on "):
                said = (Path(tmp) / "stderr").read_text(errors="replace").strip()
                raise DescriptionError(f"the reference controller's server did not start: {said or line or 'no output'}")
            yield Served(line.removeprefix("listening on ").strip(), token, "python")
        finally:
            proc.kill()
            proc.wait()
            proc.stdout.close()


def main() -> None:
    from ...engine.isolation.handshake import read_token

    p = argparse.ArgumentParser(prog="python -m tiltload.master.app.regression.mil", allow_abbrev=False)
    p.add_argument("--fmu", type=Path, required=True, help="the controller FMU whose ports the reference takes")
    p.add_argument("--token-file", type=Path, required=True)
    p.add_argument("--bind", default="127.0.0.1:0")
    p.add_argument("--scale-gain", default=None, metavar="I,J,FACTOR", help="multiply the gain's entry K[I, J] by FACTOR")
    args = p.parse_args()
    gain = None
    if args.scale_gain:
        i, j, factor = args.scale_gain.split(",")
        gain = (int(i), int(j), float(factor))
    host, _, port = args.bind.rpartition(":")
    sock = socket.create_server((host, int(port)))
    _design(TICK)  # the designs loaded before the first master waits for them
    print(f"listening on {host}:{sock.getsockname()[1]}", flush=True)

    def say(message: str) -> None:
        print(f"mil: {message}", file=sys.stderr, flush=True)
    serve(args.fmu, read_token(args.token_file), sock, say, gain)


if __name__ == "__main__":
    main()
