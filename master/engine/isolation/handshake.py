"""The first bytes on a connection to `tiltload serve`: a mutual HMAC challenge-response on a shared secret.

  server -> client   MAGIC, nonce_s (32 random bytes)
  client -> server   MAGIC, nonce_c, HMAC-SHA256(secret, "client" nonce_s nonce_c)
  server -> client   ACCEPTED, HMAC-SHA256(secret, "server" nonce_c nonce_s)   or REFUSED, then it closes

Fixed sizes, no length field: nothing a peer sends before it has proved the secret is parsed or
buffered beyond these 82 bytes. Fresh nonces on both sides: a recorded exchange cannot be
replayed, and the client knows it reached a holder of the secret too. The secret itself never
travels. What follows is not encrypted: on a link others can reach, tunnel it (docs/remote.md).
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
import socket
import stat
import time
from pathlib import Path

from ..errors import DescriptionError

MAGIC = b"tiltload-remote/1\n"
NONCE = 32
MAC = hashlib.sha256().digest_size
ACCEPTED, REFUSED = b"\x01", b"\x00"
MIN_SECRET = 16  # bytes in the token file (after surrounding white space)
MAX_TOKEN_FILE = 4096  # bytes: a secret is tens of bytes; a larger "token file" is the wrong file
# what the client's request for an FMU, which follows the handshake, says it speaks: 2 added FMI 3.0 FMUs (the request's
# tick, clocked steps in the worker); a server of 1 would take a 2 client's FMI 3.0 request and fail inside it; 3 the
# connected inputs in the init request (a server of 2 would ignore them: a feedthrough's t = 0 sample unconnected)
PROTOCOL = 3
OPEN_LIMIT = 4096  # bytes of that request and of the server's answer


class HandshakeFailed(Exception):
    """The peer is not one of ours: wrong magic, wrong secret, silence, or a closed connection."""


def read_token(path: Path) -> bytes:
    """The shared secret of a token file, which only its owner may read; a DescriptionError names what is wrong."""
    path = Path(path)
    try:  # opened without blocking (a FIFO with no writer), its type and size checked on the open file, then read
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as err:
        raise DescriptionError(f"token file {path}: {err.strerror or err}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise DescriptionError(f"token file {path} is not a regular file")
        if info.st_mode & 0o077:
            raise DescriptionError(f"token file {path} can be read by other users (chmod 600 {path})")
        if info.st_size > MAX_TOKEN_FILE:
            raise DescriptionError(f"token file {path} holds {info.st_size} bytes; a token file holds at most {MAX_TOKEN_FILE}")
        data = os.read(fd, MAX_TOKEN_FILE + 1)
    except OSError as err:
        raise DescriptionError(f"token file {path}: {err.strerror or err}") from None
    finally:
        os.close(fd)
    if len(data) > MAX_TOKEN_FILE:
        raise DescriptionError(f"token file {path} grew past {MAX_TOKEN_FILE} bytes while it was read")
    data = data.strip()
    if len(data) < MIN_SECRET:
        raise DescriptionError(f"token file {path} holds {len(data)} bytes; a secret of at least {MIN_SECRET} is needed "
                               f"(e.g. head -c 32 /dev/urandom | base64 > {path})")
    return data


def _mac(secret: bytes, role: bytes, first: bytes, second: bytes) -> bytes:
    return hmac.new(secret, role + first + second, hashlib.sha256).digest()


def _receive(sock: socket.socket, n: int, deadline: float, what: str) -> bytes:
    data = b""
    while len(data) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise HandshakeFailed(f"no {what} within the time allowed")
        sock.settimeout(left)
        try:
            chunk = sock.recv(n - len(data))
        except TimeoutError:
            raise HandshakeFailed(f"no {what} within the time allowed") from None
        except OSError as err:
            raise HandshakeFailed(f"the connection failed during {what} ({err.strerror or err})") from None
        if not chunk:
            raise HandshakeFailed(f"the connection closed before {what}" + (f" ({len(data)} of {n} bytes)" if data else ""))
        data += chunk
    return data


def _send(sock: socket.socket, data: bytes, deadline: float) -> None:
    sock.settimeout(max(deadline - time.monotonic(), 0.001))
    try:
        sock.sendall(data)
    except OSError as err:
        raise HandshakeFailed(f"the connection failed ({err.strerror or err})") from None


def server_side(sock: socket.socket, secret: bytes, timeout: float) -> None:
    """Challenge the client; return once it has proved the secret (it is then told), else HandshakeFailed."""
    deadline = time.monotonic() + timeout
    nonce_s = secrets.token_bytes(NONCE)
    _send(sock, MAGIC + nonce_s, deadline)
    magic = _receive(sock, len(MAGIC), deadline, "greeting")
    if magic != MAGIC:
        raise HandshakeFailed(f"not a tiltload client (it sent {magic[:16]!r})")
    answer = _receive(sock, NONCE + MAC, deadline, "answer to the challenge")
    nonce_c, mac = answer[:NONCE], answer[NONCE:]
    if not hmac.compare_digest(mac, _mac(secret, b"client", nonce_s, nonce_c)):
        try:
            _send(sock, REFUSED, deadline)
        except HandshakeFailed:
            pass
        raise HandshakeFailed("wrong token (its answer to the challenge does not match the secret)")
    _send(sock, ACCEPTED + _mac(secret, b"server", nonce_c, nonce_s), deadline)


def client_side(sock: socket.socket, secret: bytes, timeout: float) -> None:
    """Answer the server's challenge and check its proof; HandshakeFailed says why not."""
    deadline = time.monotonic() + timeout
    greeting = _receive(sock, len(MAGIC) + NONCE, deadline, "greeting from the server")
    if greeting[:len(MAGIC)] != MAGIC:
        raise HandshakeFailed("it is not a tiltload serve (unexpected greeting)")
    nonce_s, nonce_c = greeting[len(MAGIC):], os.urandom(NONCE)
    _send(sock, MAGIC + nonce_c + _mac(secret, b"client", nonce_s, nonce_c), deadline)
    verdict = _receive(sock, 1, deadline, "verdict on the token")
    if verdict != ACCEPTED:
        raise HandshakeFailed("it refused the token (the --token-file must hold the server's secret)")
    proof = _receive(sock, MAC, deadline, "proof of the server's token")
    if not hmac.compare_digest(proof, _mac(secret, b"server", nonce_c, nonce_s)):
        raise HandshakeFailed("it does not hold the same token (its proof does not match)")
