"""String and Binary connections (connections.TEXTS): values the tick loop's arrays do not carry, set in Python.

A target of such a connection is stepped through the loop's Python callback (native/loop.py), which sets each of its
String and Binary inputs before the step, from its source's value: the latest one (delay 0), or for a delay of d ticks
the one after tick k - d, as the loop's delay line gives numbers (tl_loop.c's group_source). A source's values are its
slave's `texts`, read after each of its steps (an FMU in this process through its callback; a worker sends them with
its outputs, isolation/wire.py). At t = 0 the inputs take the sources' values after initialization, with the numbers
(Execution._connect_initial). An input is set again only when its value changed since it was last set.
"""

from __future__ import annotations

from .connections import TEXTS, Link

_UNSET = object()


class TextLinks:
    """The String and Binary connections of an execution, and what they need between steps: the delayed sources'
    values of the last ticks, and each input's value last set."""

    def __init__(self, links: list[Link]) -> None:
        self.links = [link for link in links if link.type in TEXTS]
        self.by_target: dict[str, list[Link]] = {}
        for link in self.links:
            self.by_target.setdefault(link.target, []).append(link)
        self.targets = frozenset(self.by_target)
        self._depth = max((link.delay for link in self.links), default=0)
        self._delayed = {link.source for link in self.links if link.delay}
        self._history: dict[str, list[tuple[int, dict]]] = {}  # source -> [(the tick after which they hold, texts)]
        self._last: dict[tuple[str, str], object] = {}  # (target, input) -> the value last set

    def reset(self) -> None:
        """Before an initialization: nothing set yet, no history (a delayed input takes its source's value now)."""
        self._history, self._last = {}, {}

    def start(self, instances: dict, ticks_done: int) -> None:
        """After the initialization (or a snapshot's restore at ticks_done): the delayed sources' values now are those
        after tick ticks_done - 1 and before (a resumed run's older values are not in its snapshot)."""
        self._history = {name: [(ticks_done - 1, dict(instances[name].texts))] for name in self._delayed}

    def record(self, source: str, k: int, texts: dict) -> None:
        """A source's values after its step at tick k; only what a delay can still ask for is kept."""
        history = self._history.get(source)
        if history is None:
            return
        history.append((k, dict(texts)))
        while len(history) > 1 and history[1][0] <= k - self._depth:
            history.pop(0)

    def _value(self, instances: dict, link: Link, k: int):
        history = self._history.get(link.source)
        if link.delay == 0 or history is None:
            return instances[link.source].texts.get(link.source_name)
        held = history[0][1]
        for tick, texts in history:
            if tick > k - link.delay:
                break
            held = texts
        return held.get(link.source_name)

    def set_inputs(self, instances: dict, target: str, k: int) -> None:
        """The target's String and Binary inputs before its step at tick k (or at t = 0, k = 0)."""
        values = {}
        for link in self.by_target.get(target, ()):
            value = self._value(instances, link, k)
            if value is not None and self._last.get((target, link.target_name), _UNSET) != value:
                values[link.target_name] = value
        if values:
            instances[target].set_values(values)
            self._last.update(((target, name), value) for name, value in values.items())
