"""The server of `tiltload serve` (its command line: command_line/serve.py): the FMUs of one folder (catalogue.py), each
stepped for a master across the network as a local worker would.

A connection goes: accepted (logged, with the peer's address) → the HMAC handshake (handshake.py)
→ one JSON request naming an FMU by model identifier and GUID → a worker process (worker.py)
started from the main thread on that very socket, which instantiates the FMU and answers the
master's requests (wire.py) until it closes. Nothing a client sends is a path or code: it can
only pick one of the folder's FMUs, and only after proving the secret.

What keeps one client from harming the server or the others:
- the handshake and the request run in a thread per connection, under one deadline
  (--handshake-timeout): a client that sends nothing, garbage, a wrong token or a huge frame is
  dropped with a log line, and at most max_pending connections are being admitted at a time;
- each FMU runs in its own process (a crash costs that session only), which checks every frame
  against the model's sizes and inputs, and ends its session after idle_timeout without a request;
- each FMU serves clients_per_fmu sessions at a time (default one), the others are refused; a session's place is
  given back when its client's connection closes (a killed master's too), not when its worker ends;
- the server keeps its copy of each session's socket to see the client leave: if the worker is
  then still running (hung in the FMU), it is killed. Workers die with the server (PR_SET_PDEATHSIG,
  which follows the spawning thread: hence the main thread spawns them).
"""

from __future__ import annotations

import os
import queue
import re
import select
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from . import handshake, wire
from .catalogue import Catalogue, Refused
from .process import WORKER_MODULE, how_it_ended, worker_environment
from .transport import HEADER, Channel, FrameTooLarge, LinkClosed, LinkTimeout

MAX_TICK = 86400.0  # s: a day, the longest wait any command line allows (command_line/argument_types.DAY)

DEFAULT_PORT = 7390
GRACE = 2.0  # s a worker has to end once its client has left, before it is killed
RELEASE_WAIT = 0.5  # s a client asking for a busy FMU waits for a place given back (a client that just left) first
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,63}\Z")
_TEXT = re.compile(r"^[\x20-\x7e]{1,200}\Z")  # printable ASCII: what may reach the log from a client


@dataclass(frozen=True)
class ServeOptions:
    fmus: Path
    secret: bytes
    host: str = "127.0.0.1"
    port: int = DEFAULT_PORT
    clients_per_fmu: int = 1
    handshake_timeout: float = 5.0  # s from the connection to the FMU's pick
    idle_timeout: float = 600.0  # s a session may wait for the master's next request
    max_pending: int = 16  # connections being admitted at a time


@dataclass
class Session:
    number: int
    peer: str
    sock: socket.socket
    fmu: Path
    instance: str
    tick: float | None = None  # the master's, on which an FMI 3.0 FMU's clocks tick
    proc: subprocess.Popen | None = None
    pidfd: int | None = None
    left_at: float | None = field(default=None)  # when the client was seen to leave
    released: bool = False  # its place among the FMU's clients given back (when the client left, or at its end)

    @property
    def label(self) -> str:
        return f"#{self.number} {self.peer}"


def _peer(address) -> str:
    host, port = address[:2]
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


class Server:
    def __init__(self, options: ServeOptions, say=None) -> None:
        self.options = options
        self._say_lock = threading.Lock()
        self._external_say = say
        self.catalogue = Catalogue(options.fmus, self.say)
        self._lock = threading.Condition()  # pending, in_use; notified when a place is given back
        self._pending = 0
        self._in_use: dict[Path, int] = {}
        self._admitted: queue.Queue[Session] = queue.Queue()
        self._sessions: dict[int, Session] = {}  # by the fd the main loop watches (socket or pidfd)
        self._count = 0
        self._stopping = False
        self.listener: socket.socket | None = None
        self._wake_r, self._wake_w = os.pipe()

    def say(self, message: str) -> None:
        """One line of the server's log: stderr, with the time."""
        line = f"{time.strftime('%Y-%m-%d %H:%M:%S')} tiltload serve: {message}"
        with self._say_lock:
            if self._external_say is not None:
                self._external_say(line)
            else:
                print(line, file=sys.stderr, flush=True)

    def start(self) -> tuple[str, int]:
        """Bind and listen; the address actually bound (port 0 picks a free one)."""
        o = self.options
        family = socket.AF_INET6 if ":" in o.host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((o.host, o.port))
        sock.listen(16)
        self.listener = sock
        host, port = sock.getsockname()[:2]
        served = ", ".join(p.name for p, _ in self.catalogue.entries()) or "no FMU yet"
        self.say(f"listening on {_peer((host, port))}, serving {o.fmus} ({served}); {o.clients_per_fmu} client(s) per FMU")
        if not (host.startswith("127.") or host == "::1"):
            self.say(f"{host} is reachable from other machines: only holders of the token get in, "
                     "and the link is not encrypted (docs/remote.md)")
        return host, port

    # --- admission: one thread per connection, until the FMU is picked ---

    def _admit(self, sock: socket.socket, peer: str, number: int) -> None:
        label = f"#{number} {peer}"
        deadline = time.monotonic() + self.options.handshake_timeout
        handed_over = False
        reserved: Path | None = None
        try:
            handshake.server_side(sock, self.options.secret, self.options.handshake_timeout)
            channel = Channel.over_socket(sock)
            try:
                request = wire.decode_control(channel.receive(max(deadline - time.monotonic(), 0.001), handshake.OPEN_LIMIT))
            except LinkTimeout:
                raise Refused(f"no request for an FMU within {self.options.handshake_timeout:g} s") from None
            except LinkClosed:
                raise Refused("the connection closed before it asked for an FMU") from None
            except (FrameTooLarge, wire.ProtocolError) as err:
                raise Refused(str(err)) from None
            if channel.buffered():  # the worker takes over the stream: nothing may be waiting in our buffer
                raise Refused("it sent more than its request before the answer")
            instance, tick = self._check_request(request, label)
            fmu = self.catalogue.find(request["model_identifier"], request["guid"])
            with self._lock:
                # a client killed a moment ago: the main thread gives its place back as it sees the connection close
                self._lock.wait_for(lambda: self._in_use.get(fmu, 0) < self.options.clients_per_fmu, RELEASE_WAIT)
                if self._in_use.get(fmu, 0) >= self.options.clients_per_fmu:
                    raise Refused(f"{fmu.name} is serving {self._in_use[fmu]} client(s) already "
                                  "(tiltload serve --clients-per-fmu allows more)")
                self._in_use[fmu] = self._in_use.get(fmu, 0) + 1
                reserved = fmu
            channel.send(wire.control({"ok": True, "fmu": fmu.name, "log": []}))
            self._admitted.put(Session(number, peer, sock, fmu, instance, tick))
            handed_over = True
            os.write(self._wake_w, b"!")
        except handshake.HandshakeFailed as err:
            self.say(f"{label}: refused: {err}")
        except Refused as err:
            self.say(f"{label}: refused: {err}")
            try:
                Channel.over_socket(sock).send(wire.error("refused", str(err), False, []))
            except (LinkClosed, OSError):
                pass
        except (LinkClosed, OSError) as err:
            self.say(f"{label}: dropped: {err}")
        finally:
            if not handed_over:
                if reserved is not None:
                    self._release(reserved)
                sock.close()
            with self._lock:
                self._pending -= 1

    def _check_request(self, request: dict, label: str) -> tuple[str, float | None]:
        """The instance name and the master's tick (None: not sent) of a client's request, or Refused."""
        if request.get("op") != "open":
            raise Refused(f"expected a request for an FMU, got {str(request.get('op'))[:40]!r}")
        spoken = request.get("protocol")
        if spoken != handshake.PROTOCOL:
            named = spoken if isinstance(spoken, int) and abs(spoken) < 10**6 else repr(str(spoken)[:20])
            raise Refused(f"protocol {named}, this server speaks {handshake.PROTOCOL} (the older side's tiltload needs an "
                          "update)")
        if request.get("byteorder") != sys.byteorder:
            raise Refused(f"the master is {str(request.get('byteorder'))[:20]}-endian, this machine {sys.byteorder}-endian")
        for key in ("model_identifier", "guid", "client"):
            if not isinstance(request.get(key), str) or not _TEXT.match(request[key]):
                raise Refused(f"malformed request ({key})")
        instance = request.get("instance")
        if not isinstance(instance, str) or not _NAME.match(instance):
            raise Refused("malformed request (instance name)")
        tick = request.get("tick")
        if tick is not None and (isinstance(tick, bool) or not isinstance(tick, (int, float)) or not 0 < tick <= MAX_TICK):
            raise Refused("malformed request (tick: a positive number of seconds, at most a day)")
        self.say(f"{label}: authenticated: {request['client']} asks for {request['model_identifier']} "
                 f"{request['guid']} as {instance}")
        return instance, None if tick is None else float(tick)

    def _release(self, fmu: Path) -> None:
        with self._lock:
            self._in_use[fmu] -= 1
            self._lock.notify_all()

    def _give_back(self, s: Session) -> None:
        """The session's place among its FMU's clients, once: when its client leaves (a worker still busy in the FMU
        is then the server's to end, not a client's) or when its process ends."""
        if not s.released:
            s.released = True
            self._release(s.fmu)

    # --- the main thread: accept, start workers, watch sessions ---

    def _start_worker(self, s: Session) -> None:
        fd = s.sock.fileno()
        try:
            s.proc = subprocess.Popen(
                [sys.executable, "-m", WORKER_MODULE, str(s.fmu), s.instance, "--socket", str(fd),
                 "--idle-timeout", repr(self.options.idle_timeout), "--label", f"tiltload serve: {s.label}",
                 *(["--tick", repr(s.tick)] if s.tick is not None else [])],
                pass_fds=(fd,), stdin=subprocess.DEVNULL, stdout=2, env=worker_environment())
        except OSError as err:
            self.say(f"{s.label}: cannot start the FMU's process: {err}")
            self._release(s.fmu)
            s.sock.close()
            return
        self.say(f"{s.label}: serving {s.fmu.name} as {s.instance} (process {s.proc.pid})")
        try:
            s.pidfd = os.pidfd_open(s.proc.pid)
            self._sessions[s.pidfd] = s
            self._poll.register(s.pidfd, select.POLLIN)
        except (AttributeError, OSError):
            s.pidfd = None  # reaped by the periodic check instead
        self._sessions[fd] = s
        self._poll.register(fd, select.POLLRDHUP)

    def _end(self, s: Session) -> None:
        code = s.proc.wait()
        how = f"exit {code}" if code >= 0 else f"killed by signal {-code}"
        self.say(f"{s.label}: session ended ({s.instance}: {how})")
        if code < 0 and s.left_at is None:  # the FMU's process died under a master still waiting: say how
            frame = wire.error("ended", "the server stopped" if self._stopping else how_it_ended(code), True, [])
            try:
                s.sock.settimeout(0.5)
                s.sock.sendall(HEADER.pack(len(frame)) + frame)
            except OSError:
                pass
        for fd in (s.pidfd, s.sock.fileno()):
            if fd is not None and self._sessions.pop(fd, None) is not None:
                try:
                    self._poll.unregister(fd)
                except KeyError:
                    pass
        if s.pidfd is not None:
            os.close(s.pidfd)
        try:
            s.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        s.sock.close()
        self._give_back(s)

    def _client_left(self, s: Session) -> None:
        if s.left_at is None:
            s.left_at = time.monotonic()
            self._poll.unregister(s.sock.fileno())
            self._give_back(s)  # the next client is served now, not after its worker's end (up to GRACE later)

    def _check_sessions(self) -> None:
        now = time.monotonic()
        for s in {id(s): s for s in self._sessions.values()}.values():
            if s.proc.poll() is not None:
                self._end(s)
            elif s.left_at is not None and now - s.left_at > GRACE:
                self.say(f"{s.label}: the client left, its FMU's process is still busy (hung?): killed")
                s.proc.kill()
                self._end(s)

    def _accept(self) -> None:
        try:
            sock, address = self.listener.accept()
        except OSError:
            return
        self._count += 1
        number, peer = self._count, _peer(address)
        with self._lock:
            full = self._pending >= self.options.max_pending
            if not full:
                self._pending += 1
        if full:
            self.say(f"#{number} {peer}: dropped: {self.options.max_pending} connections are being admitted already")
            sock.close()
            return
        self.say(f"#{number} {peer}: connected")
        threading.Thread(target=self._admit, args=(sock, peer, number), name=f"admit-{number}", daemon=True).start()

    def serve_forever(self) -> None:
        """Until stop() (or Ctrl-C / SIGTERM, raised here): then every session's process is ended."""
        self._poll = select.poll()
        self._poll.register(self.listener.fileno(), select.POLLIN)
        self._poll.register(self._wake_r, select.POLLIN)
        try:
            while not self._stopping:
                for fd, _events in self._poll.poll(250):
                    if fd == self.listener.fileno():
                        self._accept()
                    elif fd == self._wake_r:
                        os.read(self._wake_r, 4096)
                    elif fd in self._sessions:
                        s = self._sessions[fd]
                        if fd == s.pidfd:
                            self._end(s)
                        else:
                            self._client_left(s)
                while True:
                    try:
                        self._start_worker(self._admitted.get_nowait())
                    except queue.Empty:
                        break
                self._check_sessions()
        finally:
            self.close()

    def stop(self) -> None:
        self._stopping = True
        try:
            os.write(self._wake_w, b"!")
        except OSError:
            pass

    def close(self) -> None:
        self._stopping = True
        for s in {id(s): s for s in self._sessions.values()}.values():
            if s.proc.poll() is None:
                s.proc.kill()
            self._end(s)
        if self.listener is not None:
            self.listener.close()
            self.listener = None
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass


if __name__ == "__main__":  # the command line of boards set up before it moved: one line saying where, not silence
    print("python -m tiltload.master.engine.isolation.server: the command line is now "
          "python -m tiltload.master.command_line.serve (docs/remote.md)", file=sys.stderr)
    sys.exit(2)
