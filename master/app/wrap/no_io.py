"""No I/O while a class's step is traced: a file read, a process started or a socket opened would run once, at trace
time, and its result be frozen into the FMU, never run at a tick (trace.py refuses the class, naming the line)."""

from __future__ import annotations

import sys
from pathlib import Path


class IoInStep(BaseException):
    """Raised at I/O while step is traced (a BaseException: the user's own `except Exception` lets it by)."""


IO_EVENTS = ("open", "os.remove", "os.rename", "os.replace", "os.mkdir", "os.rmdir", "os.truncate", "os.chmod",
              "os.chown", "os.link", "os.symlink", "os.utime", "os.system", "os.exec", "os.posix_spawn", "os.spawn",
              "os.fork", "os.kill", "os.killpg", "shutil.", "socket.connect", "socket.bind", "socket.sendto",
              "subprocess.Popen", "sqlite3.connect", "urllib.Request", "webbrowser.open")


class NoIoInStep:
    """While step is traced, I/O (files, processes, sockets) is refused: it would run once, at trace time, and its
    result be frozen into the FMU, never run at a tick. Imports still read their files. An audit hook (PEP 578):
    installed once per process, active only inside this block."""

    active: NoIoInStep | None = None
    _installed = False

    def __init__(self, source: Path):
        self.source = str(source)
        self.seen: tuple[str, str] | None = None  # (what, 'line N (`code`)')

    def __enter__(self):
        if not NoIoInStep._installed:
            sys.addaudithook(NoIoInStep._hook)
            NoIoInStep._installed = True
        NoIoInStep.active = self
        return self

    def __exit__(self, *exc) -> None:
        NoIoInStep.active = None

    @staticmethod
    def _hook(event: str, args: tuple) -> None:
        me = NoIoInStep.active
        if me is None or not event.startswith(IO_EVENTS) or (event == "open" and me._an_import()):
            return
        if event != "open" and event.startswith("open"):
            return  # openpty and the like are not in the list; "open" itself is the file
        if me.seen is None:
            NoIoInStep.active = None  # finding the line reads the file: not an event of the user's
            try:
                what = f"open({args[0]!r})" if event == "open" and args else event
                me.seen = (what, me._user_line())
            finally:
                NoIoInStep.active = me
        raise IoInStep(me.seen[0])

    def _an_import(self) -> bool:
        frame = sys._getframe(2)
        while frame is not None:
            if frame.f_code.co_filename.startswith("<frozen importlib"):
                return True
            frame = frame.f_back
        return False

    def _user_line(self) -> str:
        frame = sys._getframe(2)
        while frame is not None and frame.f_code.co_filename != self.source:
            frame = frame.f_back
        if frame is None:
            return f"a line outside {Path(self.source).name}"
        import linecache

        return f"line {frame.f_lineno} (`{linecache.getline(self.source, frame.f_lineno).strip()}`)"

    def refusal(self, name: str) -> str:
        what, where = self.seen
        return (f"{name}.step cannot be traced at {where}: it does I/O ({what}), which would run once while tracing "
                "and be frozen into the FMU, never at a tick; read files in __init__, write none in step")
