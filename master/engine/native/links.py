"""The isolated FMUs the tick loop steps itself, over shared memory (isolation/link.py): which they are, their hosts
taken onto their segments before each call of the kernel, and a Ctrl-C that stops a wait on one at once. A mixin of
NativeLoop (loop.py)."""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import threading
import weakref

from .codes import ErrorKind, LinkFailure
from .paths import path_of


def _close_all(fds) -> None:
    for fd in fds:
        os.close(fd)


class SharedMemoryLinks:
    """NativeLoop's linked FMUs (its slaves, instances, names, paths, plan and by_callback are the loop's)."""

    def _bind_links(self) -> None:
        """Which isolated FMUs the kernel steps over shared memory: those with a segment, unless asked through the
        callback or with a fault Python applies to their inputs (it may set them directly, a call the link has not)."""
        self._links: list[tuple[int, list]] = []
        self._wakeup = getattr(self, "_wakeup", None)  # the signal wakeup pipe (_signals_stop_the_wait)
        for i, (slave, c) in enumerate(zip(self.slaves, self.instances)):
            if getattr(slave, "segment", None) is None or self.names[i] in self.by_callback:
                continue
            c.link, c.by_callback = None, 1
            self.paths[self.names[i]] = path_of(slave)
            if c.hook_inputs:
                continue
            groups = [(g.type, [int(v) for v in g.dst_vrs]) for g in self.ex.groups.get(self.names[i], [])]
            self._links.append((i, groups))

    def _take_links(self) -> None:
        """Before a call of the kernel: every linked FMU's host on its segment (a snapshot or a reset in between
        brought it back to its pipe)."""
        for i, groups in self._links:
            c = self.instances[i]
            link = self.slaves[i].link_for(groups)
            c.link, c.by_callback = (ctypes.pointer(link), 0) if link is not None else (None, 1)
            self.paths[self.names[i]] = "kernel: shared memory (worker process)" if link is not None else path_of(self.slaves[i])

    @contextlib.contextmanager
    def _signals_stop_the_wait(self):
        """While the kernel may wait on a link: Python's signal wakeup fd set (the main thread only, and only if none is),
        so that a Ctrl-C stops the wait at once (TL_LINK_INTERRUPTED) instead of at the step's answer or its watchdog.
        A step abandoned so has its host killed (it may be hung) and its FMU marked fatal."""
        fd = -1
        if self._links and threading.current_thread() is threading.main_thread():
            if self._wakeup is None:  # made once, closed with the plan
                self._wakeup = os.pipe()
                os.set_blocking(self._wakeup[0], False)
                os.set_blocking(self._wakeup[1], False)
                weakref.finalize(self, _close_all, self._wakeup)
            previous = signal.set_wakeup_fd(self._wakeup[1], warn_on_full_buffer=False)
            if previous == -1:
                fd = self._wakeup[0]
            else:  # somebody else's: it stays, and the wait goes on to the answer
                signal.set_wakeup_fd(previous)
        for i, _ in self._links:
            if self.slaves[i].link is not None:
                self.slaves[i].link.signal_fd = fd
        try:
            yield
        finally:
            if fd >= 0:
                signal.set_wakeup_fd(-1)
                try:
                    while os.read(fd, 512):
                        pass
                except BlockingIOError:
                    pass
            for i, _ in self._links:
                if self.slaves[i].link is not None:
                    self.slaves[i].link.signal_fd = -1
            p = self.plan
            if p.error_kind == ErrorKind.LINK and p.error_status == LinkFailure.INTERRUPTED:
                self.slaves[p.error_instance].abandon_link()
