"""How a campaign can fail to finish, apart from its spec: each carries one line for the user."""

from __future__ import annotations


class ClusterError(ValueError):
    """The cluster cannot take the campaign: a malformed or unreachable scheduler address, a scheduler without
    workers, --workers that do not fit. Raised before anything is built or written."""


class CampaignIncomplete(RuntimeError):
    """The campaign stopped with runs still missing (the scheduler went away, runs failed for their environment);
    what was stored stays, and running the same command again finishes the rest. `counts`: what the results hold."""

    counts: dict | None = None
