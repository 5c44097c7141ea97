"""`tiltload serve` in a process of its own (optionally in a network namespace of its own) for the remote tests,
and clients that misbehave on purpose."""

from __future__ import annotations

import os
import queue
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

LISTENING = re.compile(r"listening on (\S+),")


def token_file(folder: Path, name: str = "token") -> Path:
    path = Path(folder) / name
    path.write_text(secrets.token_hex(32) + "\n")
    path.chmod(0o600)
    return path


class ServerProcess:
    """tiltload serve --fmus folder in a child process (its own session: its own process tree); its log is kept."""

    def __init__(self, fmus: Path, token: Path, *extra: str, bind: str = "127.0.0.1:0", netns: str | None = None,
                 engine_only: bool = False) -> None:
        """engine_only: as a board without the application runs it, `python -m tiltload.master.command_line.serve`."""
        entry = ["tiltload.master.command_line.serve"] if engine_only else ["tiltload.master.app.cli", "serve"]
        command = [sys.executable, "-m", *entry, "--fmus", str(fmus), "--token-file", str(token), "--bind", bind, *extra]
        if netns is not None:
            command = ["ip", "netns", "exec", netns, *command]
        self.proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                     text=True, start_new_session=True)
        self.lines: list[str] = []
        self._new: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        line = self.wait_for("listening on", timeout=60)
        self.address = LISTENING.search(line).group(1)
        if bind.rsplit(":", 1)[0] not in ("127.0.0.1", "0.0.0.0"):
            self.address = f"{bind.rsplit(':', 1)[0]}:{self.address.rsplit(':', 1)[1]}"

    def _read(self) -> None:
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))
            self._new.put(line.rstrip("\n"))

    def wait_for(self, text: str, timeout: float = 20.0) -> str:
        """The first log line from now on that contains text."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            try:
                line = self._new.get(timeout=max(left, 0.01))
            except queue.Empty:
                if left <= 0 or self.proc.poll() is not None:
                    raise AssertionError(f"no log line with {text!r} (server {'ended' if self.proc.poll() is not None else 'runs'}): "
                                         + "\n".join(self.lines)) from None
                continue
            if text in line:
                return line

    def count(self, text: str, n: int, timeout: float = 20.0) -> int:
        """How many log lines contain text, once there are n of them (or timeout s have passed)."""
        deadline = time.monotonic() + timeout
        while sum(text in line for line in self.lines) < n and time.monotonic() < deadline:
            time.sleep(0.05)
        return sum(text in line for line in self.lines)

    def workers(self) -> list[int]:
        """The FMU processes the server runs now."""
        out = subprocess.run(["ps", "-ww", "-eo", "pid,ppid,args"], capture_output=True, text=True).stdout.splitlines()[1:]
        server = self.server_pid()
        return [int(line.split()[0]) for line in out if int(line.split()[1]) == server and "command_line.worker" in line]

    def server_pid(self) -> int:
        """The Python process of the server (under `ip netns exec` it is the child of that)."""
        if self.proc.args[0] != "ip":
            return self.proc.pid
        out = subprocess.run(["ps", "-eo", "pid,ppid"], capture_output=True, text=True).stdout.splitlines()[1:]
        children = [int(line.split()[0]) for line in out if int(line.split()[1]) == self.proc.pid]
        return children[0] if children else self.proc.pid

    def kill(self) -> None:
        """SIGKILL to the server alone: its FMU processes must die with it (PR_SET_PDEATHSIG)."""
        os.kill(self.server_pid(), signal.SIGKILL)
        self.proc.wait()

    def stop(self) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()


def connect(address: str) -> socket.socket:
    host, port = address.rsplit(":", 1)
    return socket.create_connection((host, int(port)), timeout=10)


def netns_available() -> bool:
    return os.geteuid() == 0 and shutil.which("ip") is not None


class Namespace:
    """A network namespace joined to this one by a veth pair: the server at 10.231.0.2, the master at 10.231.0.1."""

    def __init__(self, name: str = f"tl{os.getpid()}") -> None:
        self.name, self.host_if, self.ns_if = name, f"{name}a", f"{name}b"
        self.master_ip, self.server_ip = "10.231.0.1", "10.231.0.2"
        steps = [["ip", "netns", "add", name],
                 ["ip", "link", "add", self.host_if, "type", "veth", "peer", "name", self.ns_if],
                 ["ip", "link", "set", self.ns_if, "netns", name],
                 ["ip", "addr", "add", f"{self.master_ip}/30", "dev", self.host_if],
                 ["ip", "link", "set", self.host_if, "up"],
                 ["ip", "netns", "exec", name, "ip", "addr", "add", f"{self.server_ip}/30", "dev", self.ns_if],
                 ["ip", "netns", "exec", name, "ip", "link", "set", self.ns_if, "up"],
                 ["ip", "netns", "exec", name, "ip", "link", "set", "lo", "up"]]
        try:
            for step in steps:
                subprocess.run(step, check=True, capture_output=True, text=True)
        except subprocess.CalledProcessError:
            self.remove()
            raise

    def remove(self) -> None:
        subprocess.run(["ip", "link", "del", self.host_if], capture_output=True)
        subprocess.run(["ip", "netns", "del", self.name], capture_output=True)


def board_copy(fmu: Path, out: Path, folder: str = "aarch64-linux") -> Path:
    """The FMU with only the binaries of one platform, as `tiltload build --platforms aarch64-linux` writes it."""
    import zipfile

    with zipfile.ZipFile(fmu) as z, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as copy:
        for item in z.infolist():
            if not item.filename.startswith("binaries/") or item.filename.startswith(f"binaries/{folder}/"):
                copy.writestr(item, z.read(item.filename))
    return out
