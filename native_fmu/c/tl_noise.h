/* Counter-based noise: Philox4x64-10 (Salmon et al., SC'11, "Random123"), the generator numpy
   ships as numpy.random.Philox, so tests can reproduce every draw bit for bit.

   A draw is a pure function of (key, counter): key = (seed, stream), counter = (sample index,
   component, 0, 0). No generator state is carried between calls, so a stream never depends on
   another, a snapshot needs no RNG state, and the same inputs give the same noise anywhere. */
#ifndef TL_NOISE_H
#define TL_NOISE_H

#include <math.h>
#include <stdint.h>

typedef struct {
  uint64_t v[4];
} TlPhilox4;

/* 64 x 64 -> 128 bit product in portable C (no __int128). */
static inline uint64_t tl_mulhilo64(uint64_t a, uint64_t b, uint64_t* hi) {
  uint64_t a_lo = a & 0xFFFFFFFFu, a_hi = a >> 32, b_lo = b & 0xFFFFFFFFu, b_hi = b >> 32;
  uint64_t ll = a_lo * b_lo, lh = a_lo * b_hi, hl = a_hi * b_lo, hh = a_hi * b_hi;
  uint64_t mid = (ll >> 32) + (lh & 0xFFFFFFFFu) + (hl & 0xFFFFFFFFu);
  *hi = hh + (lh >> 32) + (hl >> 32) + (mid >> 32);
  return (mid << 32) | (ll & 0xFFFFFFFFu);
}

static inline TlPhilox4 tl_philox4x64(TlPhilox4 ctr, uint64_t key0, uint64_t key1) {
  int round;
  for (round = 0; round < 10; ++round) {
    uint64_t hi0, hi1, lo0, lo1;
    if (round > 0) {
      key0 += UINT64_C(0x9E3779B97F4A7C15);
      key1 += UINT64_C(0xBB67AE8584CAA73B);
    }
    lo0 = tl_mulhilo64(UINT64_C(0xD2E7470EE14C6C93), ctr.v[0], &hi0);
    lo1 = tl_mulhilo64(UINT64_C(0xCA5A826395121157), ctr.v[2], &hi1);
    ctr.v[0] = hi1 ^ ctr.v[1] ^ key0;
    ctr.v[1] = lo1;
    ctr.v[2] = hi0 ^ ctr.v[3] ^ key1;
    ctr.v[3] = lo0;
  }
  return ctr;
}

/* 53 random bits as a double in [0, 1). */
static inline double tl_unit(uint64_t bits) { return (double)(bits >> 11) * (1.0 / 9007199254740992.0); }

/* One standard normal (Box-Muller, cosine branch) or one uniform on [-1, 1) for (seed, stream, sample, component). */
static inline double tl_noise(uint64_t seed, uint64_t stream, uint64_t sample, uint64_t component, int gaussian) {
  TlPhilox4 ctr = {{sample, component, 0, 0}};
  TlPhilox4 r = tl_philox4x64(ctr, seed, stream);
  if (gaussian) {
    double u1 = tl_unit(r.v[0]) + 1.0 / 9007199254740992.0; /* (0, 1]: log is finite */
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * tl_unit(r.v[1]));
  }
  return 2.0 * tl_unit(r.v[0]) - 1.0;
}

#endif
