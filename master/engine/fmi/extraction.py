"""FMUs unpacked into temporary folders that never outlive the process that unpacked them.

An FMU is loaded from an unpacked copy. Closing the instance removes the copy; but a process can end without
closing: an FMU that segfaults takes its worker process down, SIGKILL takes anyone down. So each copy gets a
reaper: a small `sh` child, in a session of its own (a Ctrl-C at the terminal does not reach it), that waits on
a pipe only this process holds open and removes the folder when the pipe closes, that is when the copy is
released or when this process ends, however it ends.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

PREFIX = "tiltload_fmu_"
_REAP = 'read _ignored; rm -rf -- "$1"'  # read returns at end of file: the holder released it, or is gone


class Unpacked:
    """One FMU's unpacked copy (`folder`), removed by release() or, failing that, when this process ends."""

    def __init__(self, fmu: Path | str) -> None:
        from fmpy import extract

        self.folder = tempfile.mkdtemp(prefix=PREFIX)
        self._hold, self._reaper = None, None
        read, self._hold = os.pipe()  # both ends non-inheritable: no other child keeps the reaper waiting
        try:
            self._reaper = subprocess.Popen(["/bin/sh", "-c", _REAP, "tiltload-reaper", self.folder], stdin=read,
                                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        except OSError:
            pass  # no /bin/sh: release() still removes the copy, only a crash would leave it
        finally:
            os.close(read)
        try:
            extract(str(fmu), unzipdir=self.folder)
        except BaseException:
            self.release()
            raise

    def release(self) -> None:
        """Remove the copy now (idempotent)."""
        shutil.rmtree(self.folder, ignore_errors=True)
        if self._hold is not None:
            os.close(self._hold)  # the reaper wakes, finds nothing to remove and ends
            self._hold = None
        if self._reaper is not None:
            self._reaper.poll()  # collected if already done; else subprocess collects it later
