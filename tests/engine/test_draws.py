"""The noise fault's draws in C (tl_draw.c: numpy's SeedSequence and PCG64 rewritten, numpy's own ziggurat and bounded
integers linked) against numpy's Generator, the Python manipulator's reference: equal bit for bit."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tiltload.master.engine.native import kernel

pytestmark = pytest.mark.skipif(not kernel.draws_in_c(), reason="this numpy ships no libnpyrandom.a")


def _words(*values: int):
    words = kernel.entropy_words(*values)
    return (ctypes.c_uint32 * kernel.ENTROPY_WORDS)(*words), len(words)


def test_entropy_words_are_numpy_s_seed_sequence_words():
    for values in ([0], [1, 0], [2**32], [2**64 - 1, 3], [123456789012345, 7]):
        entropy = np.random.SeedSequence(values).entropy
        assert np.array_equal(np.random.SeedSequence(kernel.entropy_words(*values)).generate_state(4),
                              np.random.SeedSequence(entropy).generate_state(4))


@settings(max_examples=400, deadline=None)
@given(seed=st.integers(0, 2**64 - 1), fault=st.integers(0, 40), tick=st.integers(0, 2**40))
def test_a_normal_drawn_in_c_is_numpy_s(seed, fault, tick):
    words, n = _words(seed, fault)
    lib = kernel.library()
    assert lib.tl_draw_normal(words, n, tick) == np.random.default_rng([seed, fault, tick]).standard_normal()


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**64 - 1), fault=st.integers(0, 40), tick=st.integers(0, 2**33), n=st.integers(0, 50))
def test_a_bounded_integer_drawn_in_c_is_numpy_s(seed, fault, tick, n):
    words, count = _words(seed, fault)
    assert kernel.library().tl_draw_bounded(words, count, tick, n) == np.random.default_rng([seed, fault, tick]).integers(0, n + 1)


def test_the_c_normals_have_the_normal_s_moments():
    """Independent of numpy: 20 000 ticks of one fault's draws, mean 0 and variance 1 within 4.5 standard errors,
    and 95.45 % within two sigma within 4.5 standard errors of the proportion."""
    words, n = _words(7, 0)
    z = np.array([kernel.library().tl_draw_normal(words, n, k) for k in range(20_000)])
    se = 1 / np.sqrt(z.size)
    assert abs(z.mean()) < 4.5 * se and abs(z.var() - 1) < 4.5 * np.sqrt(2) * se
    p = 0.9545
    assert abs(np.mean(np.abs(z) < 2) - p) < 4.5 * np.sqrt(p * (1 - p) / z.size)
