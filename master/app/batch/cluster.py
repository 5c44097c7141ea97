"""The Dask cluster of a campaign: an existing scheduler, checked before anything is built or written, or a
LocalCluster whose scheduler, dashboard and workers listen on the loopback interface only.
"""

from __future__ import annotations

import logging
import os
from contextlib import contextmanager
from pathlib import Path

from .address import DASHBOARD_PORT, SCHEDULER_PORT, SchedulerAddress, check_reachable, parse
from .errors import ClusterError
from .logs import LOGGER


def first_line(err: BaseException) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


def _check_tls_settings(address: SchedulerAddress) -> None:
    import dask

    needed = ("distributed.comm.tls.ca-file", "distributed.comm.tls.client.cert")
    if not all(dask.config.get(key, None) for key in needed):
        raise ClusterError(f"--scheduler {address}: tls:// needs Dask's TLS settings (distributed.comm.tls.ca-file, "
                           ".client.cert and .client.key, e.g. DASK_DISTRIBUTED__COMM__TLS__CA_FILE=...): docs/campaigns.md")


def _identity(address: SchedulerAddress, timeout: float) -> dict:
    """What answers at the address (Dask's identity call), within `timeout` seconds: a TimeoutError, or whatever a
    server that is no Dask server makes Dask's reader raise."""
    import asyncio

    from distributed.core import rpc
    from distributed.security import Security

    async def ask() -> dict:
        async with rpc(str(address), timeout=timeout, connection_args=Security().get_connection_args("client")) as r:
            return await r.identity()
    return asyncio.run(asyncio.wait_for(ask(), timeout))


def _ssl_error(err: BaseException) -> str | None:
    """The TLS failure behind a Dask connection error (Dask wraps it in CommClosedError), if one is."""
    import ssl

    seen = set()
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        if isinstance(err, ssl.SSLError) or "SSL" in str(err):
            text = first_line(err)
            return text[text.index("SSL"):] if "SSL" in text else text
        err = err.__cause__ or err.__context__
    return None


def connect(scheduler: str, workers: int, connect_timeout: float, worker_timeout: float):
    """A client of the scheduler at that address once it has `workers` workers; or a ClusterError within about
    connect_timeout (a bad or unreachable address, not a scheduler) or worker_timeout (too few workers) seconds."""
    address = parse(scheduler)
    if address.scheme == "tls":
        _check_tls_settings(address)
    check_reachable(address, connect_timeout)
    not_dask = (f"{address} accepts connections but does not answer as a Dask scheduler within {connect_timeout:g} s "
                f"(--connect-timeout): is it the scheduler's port (Dask's default {SCHEDULER_PORT}; the dashboard is "
                f"{DASHBOARD_PORT})?")
    try:
        identity = _identity(address, connect_timeout)
    except Exception as err:  # a time-out, or the garbage a server that is not Dask's sends (any exception type)
        LOGGER.info("asking %s who it is failed", address, exc_info=True)
        ssl_error = _ssl_error(err)
        if ssl_error is not None:
            raise ClusterError(f"the scheduler at {address} refused the TLS session ({ssl_error}): does the cluster's CA "
                               "sign this client's certificate (Dask's distributed.comm.tls.*: docs/campaigns.md)?") from None
        if address.scheme == "tcp":
            not_dask = not_dask[:-1] + ", or a TLS scheduler (tls://)?"
        raise ClusterError(not_dask) from None
    if identity.get("type") != "Scheduler":
        what = f"a Dask {identity['type'].lower()}" if isinstance(identity.get("type"), str) else "not a Dask scheduler"
        theirs = f" (its scheduler: {identity['scheduler']})" if identity.get("scheduler") else ""
        raise ClusterError(f"{address} is {what}, not the scheduler{theirs}")
    import dask
    from dask.distributed import Client

    try:
        with dask.config.set(BOUNDED):  # its connection's message log (the scheduler and workers are not ours)
            client = Client(str(address), timeout=f"{connect_timeout}s", set_as_default=False)
    except Exception as err:  # it answered a moment ago: gone since
        LOGGER.info("connecting to %s failed", address, exc_info=True)
        raise ClusterError(f"the scheduler at {address} answered, then refused the client: {first_line(err)}") from None
    try:
        wait_for_workers(client, str(address), workers, worker_timeout)
    except BaseException:
        client.close()
        raise
    LOGGER.info("connected to %s: %d workers", address, worker_count(client, connect_timeout) or 0)
    return client


def worker_count(client, timeout: float) -> int | None:
    """How many workers the scheduler has now; None if it did not say within `timeout` seconds."""
    try:
        return len(client.nthreads(callback_timeout=timeout))
    except Exception:
        return None


def wait_for_workers(client, address: str, n: int, timeout: float) -> None:
    try:
        client.wait_for_workers(n, timeout=timeout)
    except TimeoutError:
        have = worker_count(client, timeout) or 0
        raise ClusterError(f"the scheduler at {address} has {have} worker{'s' if have != 1 else ''} (waited "
                           f"{timeout:g} s for {n}, --worker-timeout): start them with: dask worker {address}") from None


# Dask's periodic chores, on a machine whose cores the runs need: its workers sample their thread's stack every 10 ms
# (the dashboard's profile), every process checks its event loop every 20 ms and its memory every 100 ms. Idle, that
# was 3 % of a core per worker and 4 % for the client and scheduler; these make it a tenth (benchmarks/campaign_native.py).
# Dask keeps its last messages of each connection and its last transitions for debugging, 1000 of each by default
# (distributed.admin.low-level-log-length): the client's log of update-graph messages holds every task's cases, the
# local cluster's scheduler (in the client's process) its compute-task messages to each worker; 32 bound what a
# campaign of 20,000 runs costs the client to what a few hundred runs cost (benchmarks/scale_20k.py).
BOUNDED = {"distributed.admin.low-level-log-length": 32}
QUIET = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
         "distributed.admin.system-monitor.interval": "5s", "distributed.worker.memory.monitor-interval": "500ms",
         **BOUNDED}


@contextmanager
def _interrupt_deferred():
    """A Ctrl-C meanwhile is noted, not raised (the caller raises it when the list is not empty): raised inside
    LocalCluster's constructor it would leave a cluster nobody holds, closed only at exit, its log on the terminal."""
    import signal
    import threading

    noted: list[int] = []
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield noted  # not ours to change (a thread, an ignored SIGINT, a handler of the caller's)
        return
    signal.signal(signal.SIGINT, lambda signum, frame: noted.append(signum))
    try:
        yield noted
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@contextmanager
def _workers_ignore_sigint(scratch: Path | None):
    """Worker processes started meanwhile ignore SIGINT from their first instruction: they are spawned through a
    two-line shell script in the scratch folder (trap '' INT, then exec Python; an ignored signal stays ignored across
    exec and Python keeps it so). A Ctrl-C at the terminal, which reaches the whole process group, then interrupts this
    process alone, which closes the cluster: no worker prints its KeyboardInterrupt. Without a scratch folder of ours,
    or on one mounted noexec, the workers start as Dask starts them."""
    import multiprocessing.spawn as spawn
    import shlex
    import sys

    if scratch is None or os.statvfs(scratch).f_flag & getattr(os, "ST_NOEXEC", 0):
        yield
        return
    wrapper = Path(scratch) / "python-ignoring-sigint"
    wrapper.write_text(f"#!/bin/sh\ntrap '' INT\nexec {shlex.quote(sys.executable)} \"$@\"\n")
    wrapper.chmod(0o700)
    before = spawn.get_executable()
    spawn.set_executable(str(wrapper))
    try:
        yield
    finally:
        spawn.set_executable(before)


def local_cluster(workers: int | None, verbose: bool = False, scratch: Path | None = None):
    """A LocalCluster on 127.0.0.1 (its scheduler, dashboard, nannies and workers), one single-threaded worker process
    per core unless `workers` says, ready to run; and its client. scratch: the workers' local directory (the caller's
    to remove; default: Dask's temporary-directory)."""
    import dask
    from dask.distributed import Client, LocalCluster

    n = workers or os.cpu_count() or 1
    cluster = client = None
    try:
        # the scheduler's and nannies' scratch space too (each Dask server makes one, with lock files): in scratch
        where = {"temporary-directory": str(scratch)} if scratch is not None else {}
        with dask.config.set({**QUIET, **where}), _workers_ignore_sigint(scratch), _interrupt_deferred() as interrupted:
            # (the nannies hand their workers the config of this moment)
            try:
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                       dashboard_address="127.0.0.1:0", worker_dashboard_address=None,
                                       local_directory=str(scratch) if scratch is not None else None,
                                       silence_logs=False if verbose else logging.CRITICAL)  # the workers' logs: quiet
                client = Client(cluster, set_as_default=False)
            except Exception:
                if interrupted:  # the Ctrl-C reached a nanny as it started ("Nanny failed to start"): it is the cause
                    raise KeyboardInterrupt from None
                raise
        if interrupted:
            raise KeyboardInterrupt
        from .worker import ready

        client.run(ready)  # each new worker imports the runs' module now: part of the start, not of the first run
    except BaseException:  # a Ctrl-C while it starts: closed here, while the campaign's log still takes Dask's records
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
        raise
    LOGGER.info("local cluster: scheduler %s, dashboard %s, %d workers", cluster.scheduler_address,
                cluster.dashboard_link, n)
    return client, cluster
