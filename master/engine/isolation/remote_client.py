"""The master's side of an FMU served by `tiltload serve` on another machine (server.py): the host of an IsolatedFmu.

Connecting is: TCP (Nagle off), the HMAC handshake (handshake.py), then one request naming the FMU
by model identifier and GUID (the server picks it from its folder; nothing is sent but names),
then the worker the server started greets as a local worker would. From there the messages
are the local worker's (wire.py): one round trip per step.
"""

from __future__ import annotations

import os
import socket
import sys

from ..errors import ExecutionError
from ..system import parse_address
from . import handshake, wire
from .transport import Channel, FrameTooLarge, LinkClosed, LinkTimeout

CONNECT_TIMEOUT = 10.0  # s to reach the server, prove the token and have the FMU picked


class RemoteHost:
    """A connection to `tiltload serve` carrying one FMU instance."""

    def __init__(self, address: str, secret: bytes, name: str, md, tick: float | None = None,
                 timeout: float = CONNECT_TIMEOUT) -> None:
        """tick: the execution's, sent with the request (the server's worker places an FMI 3.0 FMU's clocks on it)."""
        self.address = address
        self.where = f"tiltload serve at {address}"
        where = f"{name}: {self.where}"
        host, port = parse_address(address)
        try:
            sock = socket.create_connection((host, port), timeout=timeout)
        except OSError as err:
            raise ExecutionError(f"{where}: cannot connect ({err.strerror or err})") from None
        try:
            handshake.client_side(sock, secret, timeout)
            self.channel = Channel.over_socket(sock)
        except handshake.HandshakeFailed as err:
            sock.close()
            raise ExecutionError(f"{where}: {err}") from None
        try:
            self.channel.send(wire.control({
                "op": "open", "protocol": handshake.PROTOCOL, "model_identifier": md.coSimulation.modelIdentifier, "guid": md.guid,
                "instance": name, "byteorder": sys.byteorder, "client": f"{socket.gethostname()} pid {os.getpid()}",
                **({"tick": float(tick)} if tick is not None else {})}))
            reply = wire.decode_reply(self.channel.receive(timeout, handshake.OPEN_LIMIT))
        except (LinkClosed, LinkTimeout, FrameTooLarge, wire.ProtocolError) as err:
            self.channel.close()
            raise ExecutionError(f"{where}: no answer to the request for {md.coSimulation.modelIdentifier} "
                                 f"({type(err).__name__}: {err})") from None
        if reply.get("ok") is not True:
            self.channel.close()
            raise ExecutionError(f"{where}: {reply['message']}")
        self.served = reply.get("fmu", "?")

    def ended(self, what: str) -> str:
        return (f"the connection to tiltload serve at {self.address} was lost in {what} "
                "(the server, its FMU's process or the network went away)")

    def cut_off(self) -> str:
        self.channel.close()  # the server kills the FMU's process once it sees the connection end
        return f"the connection to {self.address} was closed"

    def close(self) -> None:
        self.channel.close()

