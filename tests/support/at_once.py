"""Run one function in several threads released together: a race, when there is one, shows."""

from __future__ import annotations

import threading


def at_once(task, n: int = 8) -> tuple[list, list[str]]:
    """task() in n threads started by one barrier: (what each returned, the repr of what each raised)."""
    start, results, errors = threading.Barrier(n), [], []

    def run():
        start.wait()
        try:
            results.append(task())
        except Exception as e:  # noqa: BLE001 - the caller asserts on what any thread met
            errors.append(repr(e))

    threads = [threading.Thread(target=run) for _ in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return results, errors
