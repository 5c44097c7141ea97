"""A campaign's log: Dask's records (and its tracebacks) go to <out>/campaign.log, not to the user's terminal;
--verbose shows them on the terminal as well.

Until the results folder exists (nothing is written before the scheduler is checked), the records wait in memory.
"""

from __future__ import annotations

import logging
import logging.handlers
from contextlib import contextmanager
from pathlib import Path

LOG = "campaign.log"
LOGGER = logging.getLogger("tiltload.campaign")  # the campaign's own records: retries, failures, the cluster
_TAKEN = ("distributed", "tornado", "bokeh", "asyncio", "py.warnings", LOGGER.name)  # and the loggers below them


class CampaignLog:
    def __init__(self) -> None:
        # not a StreamHandler: Dask's silence_logs lowers the StreamHandlers of its loggers, not this one
        self.handler = logging.handlers.MemoryHandler(capacity=1, target=None, flushOnClose=True)
        self.path: Path | None = None

    def to_file(self, path: Path) -> None:
        """From now on (and what waited until now) into this file, appended."""
        target = logging.FileHandler(path, mode="a", encoding="utf-8")
        target.setFormatter(logging.Formatter("%(asctime)s %(name)s %(levelname)s: %(message)s"))
        self.handler.setTarget(target)
        self.handler.flush()
        self.path = path

    def close(self) -> None:
        self.handler.close()
        if self.handler.target is not None:
            self.handler.target.close()


def _loggers() -> list[logging.Logger]:
    names = [n for n in logging.root.manager.loggerDict if any(n == t or n.startswith(t + ".") for t in _TAKEN)]
    found = {n: logging.getLogger(n) for n in (*_TAKEN, *names)}
    # the top of each family, and those below it that Dask gave handlers of their own (they do not propagate)
    return [lg for n, lg in found.items() if n in _TAKEN or lg.handlers]


@contextmanager
def campaign_log(verbose: bool = False):
    """Route Dask's logging to a CampaignLog for the duration (restored after); with verbose, the terminal keeps it too."""
    import distributed  # noqa: F401  (its import gives its loggers their terminal handlers: take them after that)

    log = CampaignLog()
    saved = []
    for lg in _loggers():
        saved.append((lg, list(lg.handlers), lg.propagate, lg.level))
        terminal = (list(lg.handlers) or [logging.StreamHandler()]) if verbose else []
        lg.handlers = [log.handler, *terminal]
        lg.propagate = False
    LOGGER.setLevel(logging.INFO)
    logging.captureWarnings(not verbose)  # Dask's warnings too; with --verbose they print as usual
    try:
        yield log
    finally:
        logging.captureWarnings(False)
        for lg, handlers, propagate, level in saved:
            lg.handlers, lg.propagate = handlers, propagate
            lg.setLevel(level)
        log.close()
