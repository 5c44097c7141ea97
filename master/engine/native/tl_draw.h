/* The draws of the noise fault, made in C exactly as numpy makes them in Python:
   np.random.default_rng([seed, fault, tick]).standard_normal() (and .integers(0, n + 1)). numpy's SeedSequence and
   PCG64 are reimplemented here; the normal and bounded draws are numpy's own (libnpyrandom, shipped with numpy for C
   consumers). tests/engine/test_draws.py compares them with numpy. */
#ifndef TL_DRAW_H
#define TL_DRAW_H

#include <stdint.h>

#include "tl_codes.h" /* TL_ENTROPY_WORDS: the fault's own words (seed, place) at most */

/* The standard normal of numpy's default_rng(entropy + [tick]), the entropy given as numpy's uint32 words. */
double tl_draw_normal(const uint32_t *entropy, int n_entropy, uint64_t tick);
/* default_rng(entropy + [tick]).integers(0, n + 1) */
uint64_t tl_draw_bounded(const uint32_t *entropy, int n_entropy, uint64_t tick, uint64_t n);

#endif
