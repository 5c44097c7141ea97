"""The link between the master and an FMU's host: length-prefixed frames over a pipe pair or a TCP socket.

One class for both: a pipe pair is two file descriptors, a socket is one used both ways, and the
frames, the deadline and the size check are the same. Reading waits with poll() (no limit on the
descriptor's number, unlike select) and takes what has arrived in one read: a step's reply is
usually one system call.
"""

from __future__ import annotations

import errno
import os
import select
import socket
import struct
import time

HEADER = struct.Struct("<I")  # the length of the frame that follows
_CHUNK = 1 << 16
_GONE = (errno.ECONNRESET, errno.EPIPE, errno.ENOTCONN, errno.ECONNABORTED, errno.ETIMEDOUT, errno.EHOSTUNREACH)


class LinkClosed(Exception):
    """The other side closed the link (its process ended, or the connection was lost)."""


class LinkTimeout(Exception):
    """Nothing (or not all of a frame) arrived before the deadline."""


class FrameTooLarge(Exception):
    """The other side announced a frame longer than this side accepts."""

    def __init__(self, size: int, limit: int) -> None:
        super().__init__(f"a frame of {size} bytes announced, at most {limit} accepted")
        self.size, self.limit = size, limit


class Channel:
    """Frames both ways over a read and a write descriptor (the same one for a socket)."""

    def __init__(self, read_fd: int, write_fd: int, owner=None) -> None:
        self.read_fd, self.write_fd = read_fd, write_fd
        self._owner = owner  # the socket object the descriptor belongs to, kept alive and shut down on close
        self._poll = select.poll()
        self._poll.register(read_fd, select.POLLIN | select.POLLPRI)
        self._buffer = bytearray()
        self.closed = False

    @classmethod
    def over_pipes(cls, read_fd: int, write_fd: int) -> Channel:
        return cls(read_fd, write_fd)

    @classmethod
    def over_socket(cls, sock: socket.socket) -> Channel:
        """A connected TCP socket: Nagle off, so a step's small frame leaves at once (one round trip per step)."""
        sock.setblocking(True)
        if sock.family in (socket.AF_INET, socket.AF_INET6):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return cls(sock.fileno(), sock.fileno(), owner=sock)

    def send(self, data: bytes) -> None:
        view = memoryview(HEADER.pack(len(data)) + data)
        try:
            while view:
                view = view[os.write(self.write_fd, view):]
        except OSError as err:
            if isinstance(err, BrokenPipeError) or err.errno in _GONE:
                raise LinkClosed(str(err)) from None
            raise

    def _fill(self, deadline: float | None) -> None:
        """Read what has arrived (waiting until deadline, None: forever) into the buffer."""
        while True:
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                raise LinkTimeout()
            ready = self._poll.poll(None if left is None else max(1, int(left * 1000 + 0.999)))
            if ready:
                break
        try:
            chunk = os.read(self.read_fd, _CHUNK)
        except OSError as err:
            if err.errno in _GONE:
                raise LinkClosed(str(err)) from None
            raise
        if not chunk:
            raise LinkClosed("end of stream")
        self._buffer += chunk

    def receive(self, timeout: float | None = None, limit: int | None = None) -> bytes:
        """The next frame, within timeout seconds (None: wait for ever); LinkTimeout, LinkClosed, or FrameTooLarge
        as soon as a header announces more than limit bytes (nothing more is read)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while len(self._buffer) < HEADER.size:
            self._fill(deadline)
        (size,) = HEADER.unpack_from(self._buffer)
        if limit is not None and size > limit:
            raise FrameTooLarge(size, limit)
        while len(self._buffer) < HEADER.size + size:
            self._fill(deadline)
        frame = bytes(self._buffer[HEADER.size:HEADER.size + size])
        del self._buffer[:HEADER.size + size]
        return frame

    def buffered(self) -> int:
        """Bytes received past the last frame returned (a peer that sent ahead of its answer)."""
        return len(self._buffer)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        if self._owner is not None:
            try:
                self._owner.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            self._owner.close()
            return
        for fd in {self.read_fd, self.write_fd}:
            try:
                os.close(fd)
            except OSError:
                pass
