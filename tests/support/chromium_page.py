"""Headless Chromium driven over its DevTools protocol on a pipe (--remote-debugging-pipe: commands on fd 3, replies
on fd 4, each a JSON message ended by NUL), with the stdlib only: open a page at a width, read what it measures."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
from pathlib import Path


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def _onto_3_and_4(read_end: int, write_end: int) -> None:
    """In the child: its fd 3 the pipe it reads commands from, fd 4 the one it answers on (through copies, as either
    may already be 3 or 4)."""
    r, w = os.dup(read_end), os.dup(write_end)
    os.dup2(r, 3)
    os.dup2(w, 4)


class Browser:
    """One headless Chromium with a fresh profile; `measure(page, width, script)` evaluates script on the page laid out
    at width CSS pixels."""

    def __init__(self, timeout: float = 180.0):
        self._profile = tempfile.TemporaryDirectory(prefix="tl-chromium-")
        to_child_r, self._to_child = os.pipe()
        self._from_child, from_child_w = os.pipe()
        # the child's fd 3 reads what we write, its fd 4 writes what we read
        self._proc = subprocess.Popen(
            [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
             "--disable-component-update", "--no-first-run", "--remote-debugging-pipe",
             f"--user-data-dir={self._profile.name}", "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            pass_fds=(3, 4, to_child_r, from_child_w), preexec_fn=lambda: _onto_3_and_4(to_child_r, from_child_w))
        os.close(to_child_r)
        os.close(from_child_w)
        self._timeout, self._id, self._buffer = timeout, 0, b""

    def _send(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        self._id += 1
        message = {"id": self._id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self._to_child, json.dumps(message).encode() + b"\0")
        while True:
            reply = self._next()
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]

    def _next(self) -> dict:
        import select

        while b"\0" not in self._buffer:
            ready, _, _ = select.select([self._from_child], [], [], self._timeout)
            chunk = os.read(self._from_child, 1 << 20) if ready else b""
            if not chunk:
                raise RuntimeError("chromium stopped answering")
            self._buffer += chunk
        raw, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(raw)

    def _wait_for(self, event: str) -> None:
        while self._next().get("method") != event:
            pass

    def measure(self, page: Path, width: int, script: str, height: int = 900):
        """The value of script (an expression; JSON-serialisable) on page laid out width CSS pixels wide."""
        target = self._send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self._send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        try:
            self._send("Emulation.setDeviceMetricsOverride",
                       {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False}, session)
            self._send("Page.enable", {}, session)
            self._send("Page.navigate", {"url": Path(page).resolve().as_uri()}, session)
            self._wait_for("Page.loadEventFired")
            found = self._send("Runtime.evaluate", {"expression": script, "returnByValue": True}, session)
            return found["result"].get("value")
        finally:
            self._send("Target.closeTarget", {"targetId": target})

    def close(self) -> None:
        try:
            self._send("Browser.close")
        except (RuntimeError, OSError):
            pass
        try:
            self._proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        os.close(self._to_child)
        os.close(self._from_child)
        self._profile.cleanup()
