/* numpy's SeedSequence (pool of 4 words, no spawn key) and PCG64 (XSL-RR 128/64), in C. See tl_draw.h. */
#include "tl_draw.h"

#include <stdbool.h>
#include <stddef.h>

#include "numpy/random/bitgen.h"

#define TL_EXPORT __attribute__((visibility("default")))

/* libnpyrandom's (numpy/random/distributions.h, which needs Python.h: declared here instead) */
extern double random_standard_normal(bitgen_t *bitgen_state);
extern void random_bounded_uint64_fill(bitgen_t *bitgen_state, uint64_t off, uint64_t rng, intptr_t cnt,
                                       bool use_masked, uint64_t *out);

enum { POOL = 4 };
static const uint32_t INIT_A = 0x43b0d7e5u, MULT_A = 0x931e8875u, INIT_B = 0x8b51f9ddu, MULT_B = 0x58f38dedu;
static const uint32_t MIX_MULT_L = 0xca01f9ddu, MIX_MULT_R = 0x4973f715u;

static uint32_t hashmix(uint32_t value, uint32_t *hash_const) {
    value ^= *hash_const;
    *hash_const *= MULT_A;
    value *= *hash_const;
    return value ^ (value >> 16);
}

static uint32_t mix(uint32_t x, uint32_t y) {
    uint32_t r = MIX_MULT_L * x - MIX_MULT_R * y;
    return r ^ (r >> 16);
}

/* SeedSequence(entropy).generate_state(4, uint64): the seed and increment PCG64 starts from */
static void seed_state(const uint32_t *entropy, int n, uint64_t out[4]) {
    uint32_t pool[POOL], h = INIT_A;
    for (int i = 0; i < POOL; i++) pool[i] = hashmix(i < n ? entropy[i] : 0u, &h);
    for (int s = 0; s < POOL; s++)
        for (int d = 0; d < POOL; d++)
            if (s != d) pool[d] = mix(pool[d], hashmix(pool[s], &h));
    for (int s = POOL; s < n; s++)
        for (int d = 0; d < POOL; d++) pool[d] = mix(pool[d], hashmix(entropy[s], &h));
    uint32_t hb = INIT_B, words[8];
    for (int i = 0; i < 8; i++) {
        uint32_t v = pool[i % POOL] ^ hb;
        hb *= MULT_B;
        v *= hb;
        words[i] = v ^ (v >> 16);
    }
    for (int i = 0; i < 4; i++) out[i] = (uint64_t)words[2 * i] | (uint64_t)words[2 * i + 1] << 32;
}

__extension__ typedef unsigned __int128 u128; /* GCC and Clang on 64-bit targets */

typedef struct {
    u128 state, inc;
    int has_uint32;
    uint32_t uinteger;
} pcg64;

static const u128 PCG_MULT = ((u128)2549297995355413924ull << 64) | 4865540595714422341ull;

static uint64_t next64(void *st) {
    pcg64 *g = st;
    g->state = g->state * PCG_MULT + g->inc;
    uint64_t x = (uint64_t)(g->state >> 64) ^ (uint64_t)g->state;
    unsigned r = (unsigned)(g->state >> 122);
    return (x >> r) | (x << ((64u - r) & 63u));
}

static uint32_t next32(void *st) { /* the high half of a draw is kept for the next call, as numpy does */
    pcg64 *g = st;
    if (g->has_uint32) {
        g->has_uint32 = 0;
        return g->uinteger;
    }
    uint64_t x = next64(g);
    g->has_uint32 = 1;
    g->uinteger = (uint32_t)(x >> 32);
    return (uint32_t)x;
}

static double next_double(void *st) { return (double)(next64(st) >> 11) * (1.0 / 9007199254740992.0); }

static uint64_t next_raw(void *st) { return next64(st); }

/* default_rng(entropy + [tick]): the tick's words appended as numpy's _coerce_to_uint32_array does */
static void seeded(const uint32_t *entropy, int n, uint64_t tick, pcg64 *g, bitgen_t *bitgen) {
    uint32_t words[TL_ENTROPY_WORDS + 2];
    int m = n < TL_ENTROPY_WORDS ? n : TL_ENTROPY_WORDS;
    for (int i = 0; i < m; i++) words[i] = entropy[i];
    words[m++] = (uint32_t)tick;
    if (tick >> 32) words[m++] = (uint32_t)(tick >> 32);
    uint64_t s[4];
    seed_state(words, m, s);
    u128 seed = (u128)s[0] << 64 | s[1], initseq = (u128)s[2] << 64 | s[3];
    g->state = 0;
    g->inc = (initseq << 1) | 1u;
    g->state = g->state * PCG_MULT + g->inc;
    g->state += seed;
    g->state = g->state * PCG_MULT + g->inc;
    g->has_uint32 = 0;
    g->uinteger = 0;
    *bitgen = (bitgen_t){.state = g, .next_uint64 = next64, .next_uint32 = next32, .next_double = next_double,
                         .next_raw = next_raw};
}

TL_EXPORT double tl_draw_normal(const uint32_t *entropy, int n_entropy, uint64_t tick) {
    pcg64 g;
    bitgen_t b;
    seeded(entropy, n_entropy, tick, &g, &b);
    return random_standard_normal(&b);
}

TL_EXPORT uint64_t tl_draw_bounded(const uint32_t *entropy, int n_entropy, uint64_t tick, uint64_t n) {
    pcg64 g;
    bitgen_t b;
    uint64_t out;
    seeded(entropy, n_entropy, tick, &g, &b);
    random_bounded_uint64_fill(&b, 0, n, 1, false, &out);
    return out;
}
