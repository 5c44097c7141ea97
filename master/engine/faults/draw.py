"""The random draws of the noise and jitter faults, a pure function of (seed, fault, tick)."""

from __future__ import annotations

import ctypes

import numpy as np

from .schedule import SEEDS, Fault


class Draws:
    """The draws of noise and jitter: those of numpy's default_rng([seed, fault, tick]), a pure function of the three
    (the same with any batching, after a snapshot, in any worker). Made by the kernel's C (tl_draw.c, equal to numpy
    bit for bit, 30-45x cheaper than seeding a Generator) when it has them, else by numpy."""

    def __init__(self, faults: list[Fault]) -> None:
        from ..native import kernel

        self.seeds = [f.seed for f in faults]
        self.lib = kernel.library() if kernel.draws_in_c() and all(f.seed < SEEDS for f in faults) else None
        if self.lib is not None:
            self.words = []
            for k, f in enumerate(faults):
                words = kernel.entropy_words(f.seed, k)
                self.words.append(((ctypes.c_uint32 * len(words))(*words), len(words)))

    def normal(self, k: int, tick: int) -> float:
        if self.lib is None:
            return float(np.random.default_rng([self.seeds[k], k, tick]).standard_normal())
        return self.lib.tl_draw_normal(*self.words[k], tick)

    def bounded(self, k: int, tick: int, n: int) -> int:
        """An integer in 0..n"""
        if self.lib is None:
            return int(np.random.default_rng([self.seeds[k], k, tick]).integers(0, n + 1))
        return int(self.lib.tl_draw_bounded(*self.words[k], tick, n))

