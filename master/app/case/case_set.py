"""One run of a case set (a campaign's case, a search's point), as the batch runtime dispatches it: its id, controller,
seed, the varied values by name and the parameters by target (the grammar of targets.py)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Case:
    """One run: its id (a hash of everything that defines it), controller, seed and parameter values."""

    run_id: str
    controller: str
    seed: int
    values: dict[str, float]  # by varied name
    parameters: dict[str, object] = field(default_factory=dict)  # by instance.name, base and varied
