"""A Dask scheduler's address, checked before a campaign builds or writes anything: its scheme, host and port, then
whether anything answers there within a short timeout.

Dask takes `HOST:PORT` as tcp://HOST:PORT; so do we. tls:// needs Dask's TLS settings (docs/campaigns.md).
"""

from __future__ import annotations

import ipaddress
import re
import socket
import threading
from dataclasses import dataclass

from .errors import ClusterError

SCHEMES = ("tcp", "tls")
SCHEDULER_PORT, DASHBOARD_PORT = 8786, 8787  # Dask's defaults
_HOSTNAME = re.compile(r"^(?=.{1,253}$)[A-Za-z0-9_]([A-Za-z0-9_-]*[A-Za-z0-9_])?(\.[A-Za-z0-9_]([A-Za-z0-9_-]*[A-Za-z0-9_])?)*\.?\Z")


@dataclass(frozen=True)
class SchedulerAddress:
    scheme: str
    host: str
    port: int

    def __str__(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{self.scheme}://{host}:{self.port}"


def parse(text: str) -> SchedulerAddress:
    """The address of `--scheduler`, or a ClusterError saying what is wrong with it."""
    form = f"a Dask scheduler's address is tcp://HOST:PORT or tls://HOST:PORT (port {SCHEDULER_PORT} by default)"
    text = (text or "").strip()
    if not text:
        raise ClusterError(f"--scheduler is empty: {form}; leave --scheduler out for a local cluster")
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    scheme = scheme.lower()
    if scheme in ("http", "https"):
        raise ClusterError(f"--scheduler {text}: {scheme}:// is the dashboard's (port {DASHBOARD_PORT} by default); {form}")
    if scheme not in SCHEMES:
        raise ClusterError(f"--scheduler {text}: unknown scheme {scheme}://; {form}")
    rest = rest[:-1] if rest.endswith("/") else rest
    if any(c in rest for c in "/?#@ "):
        raise ClusterError(f"--scheduler {text}: {form}, with nothing after the port")
    if rest.startswith("["):  # [IPv6]:port
        host, close, tail = rest[1:].partition("]")
        if not close or (tail and not tail.startswith(":")):
            raise ClusterError(f"--scheduler {text}: an IPv6 host is written [ADDRESS]:PORT")
        port = tail[1:] if tail else None
    else:
        if rest.count(":") > 1:
            raise ClusterError(f"--scheduler {text}: an IPv6 host is written in brackets, tcp://[ADDRESS]:PORT")
        host, colon, port = rest.partition(":")
        port = port if colon else None
    if not host:
        raise ClusterError(f"--scheduler {text}: no host; {form}")
    if port is None or port == "":
        raise ClusterError(f"--scheduler {text}: no port; {form}")
    if not port.isdigit() or not 1 <= int(port) <= 65535:
        raise ClusterError(f"--scheduler {text}: the port must be a number from 1 to 65535, got {port!r}")
    if not _valid_host(host):
        raise ClusterError(f"--scheduler {text}: {host!r} is neither a host name nor an IP address")
    return SchedulerAddress(scheme, host, int(port))


def _valid_host(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
        return True
    except ValueError:
        return bool(_HOSTNAME.match(host))


def _resolve(address: SchedulerAddress, timeout: float) -> list[tuple]:
    """getaddrinfo within the timeout (the resolver's own can be much longer): in a thread we may leave behind."""
    found: dict = {}

    def look_up() -> None:
        try:
            found["infos"] = socket.getaddrinfo(address.host, address.port, type=socket.SOCK_STREAM)
        except OSError as err:
            found["error"] = err
    thread = threading.Thread(target=look_up, daemon=True)
    thread.start()
    thread.join(timeout)
    if thread.is_alive():
        raise ClusterError(f"--scheduler {address}: the host name {address.host} did not resolve within {timeout:g} s "
                           "(--connect-timeout)")
    if "error" in found:
        err = found["error"]
        raise ClusterError(f"--scheduler {address}: unknown host {address.host} ({getattr(err, 'strerror', None) or err})")
    return found["infos"]


def check_reachable(address: SchedulerAddress, timeout: float) -> None:
    """Something accepts TCP connections at the address within `timeout` seconds; or a ClusterError saying what not."""
    import time

    deadline = time.monotonic() + timeout
    infos = _resolve(address, timeout)
    error: OSError | None = None
    for family, kind, proto, _, where in infos:
        left = deadline - time.monotonic()
        if left <= 0:
            break
        with socket.socket(family, kind, proto) as s:
            s.settimeout(left)
            try:
                s.connect(where)
                return
            except OSError as err:
                error = err
    if error is None or isinstance(error, TimeoutError):
        raise ClusterError(f"the scheduler at {address} did not answer within {timeout:g} s (--connect-timeout): "
                           "is the host up and the port open?")
    if isinstance(error, ConnectionRefusedError):
        raise ClusterError(f"nothing listens at {address} (connection refused): is the scheduler running, on this port?")
    raise ClusterError(f"the scheduler at {address} cannot be reached: {error.strerror or error}")
