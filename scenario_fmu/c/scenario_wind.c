/* Dryden turbulence, wind profile (scenario_wind.h).

   Filters, with a = V / L and unit-intensity white noise n (so the one-sided spectra of MIL-F-8785C, whose
   integrals are sigma^2, come out):
     u:    x' = -a x + n,                           u = sigma sqrt(2 a) x                  (H_u of the standard)
     v, w: x1' = -a x1 + x2, x2' = -a x2 + n,        v = sigma a^1.5 ((1 - sqrt 3) x1 + sqrt(3)/a x2)
   The exact discretization over h: x+ = e^{Ah} x + L n_k with L L' = Q_d = int_0^h e^{As} B B' e^{A's} ds
   in closed form (below), so the samples have the continuous model's covariance for any h. */
#include "tl_platform.h"

#include "scenario_wind.h"

#include <math.h>

#include "tl_noise.h"

#define FT 0.3048
#define KNOT 0.514444
#define WIND_STREAM UINT64_C(0x44727964656E) /* "Dryden": apart from the sensor suite's streams (group indices) */

void tl_dryden_parameters(int severity, double altitude, double airspeed, const double steady[3], TlDryden* d) {
  double h = altitude / FT, w20 = 15.0 * KNOT * severity, base = 0.177 + 0.000823 * h;
  double speed = sqrt(steady[0] * steady[0] + steady[1] * steady[1] + steady[2] * steady[2]);
  d->sigma[2] = 0.1 * w20;
  d->sigma[0] = d->sigma[1] = d->sigma[2] / pow(base, 0.4);
  d->length[2] = altitude;
  d->length[0] = d->length[1] = h / pow(base, 1.2) * FT;
  d->airspeed = airspeed > 0.0 ? airspeed : speed > 0.0 ? speed : w20;
}

/* g_k(y) = 1 - e^{-y} sum_{n<k} y^n / n!, by its series below y = 1 (where the difference would cancel). */
static double tail(int k, double y) {
  double term = 1.0, sum = 0.0;
  int n;
  if (y >= 1.0) {
    for (n = 0; n < k; ++n) {
      sum += term;
      term *= y / (n + 1);
    }
    return 1.0 - exp(-y) * sum;
  }
  for (n = 1; n <= k; ++n) term *= y / n; /* y^k / k! */
  for (n = k; term > 1e-18 * sum; ++n) {
    sum += term;
    term *= y / (n + 1);
  }
  return exp(-y) * sum;
}

static double normal(uint64_t seed, uint64_t sample, uint64_t component) {
  return tl_noise(seed, WIND_STREAM, sample, component, 1);
}

void tl_dryden_start(const TlDryden* d, uint64_t seed, double x[TL_DRYDEN_STATES]) {
  int c;
  double a = d->airspeed / d->length[0];
  x[0] = sqrt(1.0 / (2.0 * a)) * normal(seed, 0, 0);
  for (c = 1; c < 3; ++c) { /* P = [1/(4a^3) 1/(4a^2); 1/(4a^2) 1/(2a)] */
    double l11, l21, l22;
    a = d->airspeed / d->length[c];
    l11 = sqrt(1.0 / (4.0 * a * a * a));
    l21 = 1.0 / (4.0 * a * a) / l11;
    l22 = sqrt(1.0 / (2.0 * a) - l21 * l21);
    x[2 * c - 1] = l11 * normal(seed, 0, 2 * c - 1);
    x[2 * c] = l21 * normal(seed, 0, 2 * c - 1) + l22 * normal(seed, 0, 2 * c);
  }
}

static void discretize(const TlDryden* d, double h, TlDrydenStep* q) {
  int c;
  double a = d->airspeed / d->length[0];
  q->h = h;
  q->decay[0] = exp(-a * h);
  q->chol[0][0] = sqrt(tail(1, 2.0 * a * h) / (2.0 * a));
  for (c = 1; c < 3; ++c) {
    double y, i0, i1, i2;
    a = d->airspeed / d->length[c];
    y = 2.0 * a * h;
    q->decay[c] = exp(-a * h);
    i0 = tail(1, y) / (2.0 * a);
    i1 = tail(2, y) / (4.0 * a * a);
    i2 = 2.0 * tail(3, y) / (8.0 * a * a * a);
    q->chol[c][0] = sqrt(i2);
    q->chol[c][1] = i1 / q->chol[c][0];
    q->chol[c][2] = sqrt(fmax(i0 - q->chol[c][1] * q->chol[c][1], 0.0));
  }
}

void tl_dryden_step(const TlDryden* d, uint64_t seed, uint64_t sample, double h, TlDrydenStep* q, double x[TL_DRYDEN_STATES]) {
  int c;
  if (q->h != h) discretize(d, h, q);
  x[0] = q->decay[0] * x[0] + q->chol[0][0] * normal(seed, sample, 0);
  for (c = 1; c < 3; ++c) {
    double n1 = normal(seed, sample, 2 * c - 1), n2 = normal(seed, sample, 2 * c), x1 = x[2 * c - 1], x2 = x[2 * c];
    x[2 * c - 1] = q->decay[c] * (x1 + h * x2) + q->chol[c][0] * n1;
    x[2 * c] = q->decay[c] * x2 + q->chol[c][1] * n1 + q->chol[c][2] * n2;
  }
}

void tl_dryden_output(const TlDryden* d, const double x[TL_DRYDEN_STATES], double uvw[3]) {
  int c;
  double a = d->airspeed / d->length[0], r3 = sqrt(3.0);
  uvw[0] = d->sigma[0] * sqrt(2.0 * a) * x[0];
  for (c = 1; c < 3; ++c) {
    a = d->airspeed / d->length[c];
    uvw[c] = d->sigma[c] * a * sqrt(a) * ((1.0 - r3) * x[2 * c - 1] + r3 / a * x[2 * c]);
  }
}

void tl_wind_axes(const double steady[3], double axes[3][3]) {
  double horizontal = sqrt(steady[0] * steady[0] + steady[1] * steady[1]);
  double ux = horizontal > 0.0 ? steady[0] / horizontal : 1.0, uy = horizontal > 0.0 ? steady[1] / horizontal : 0.0;
  axes[0][0] = ux, axes[0][1] = uy, axes[0][2] = 0.0;
  axes[1][0] = -uy, axes[1][1] = ux, axes[1][2] = 0.0;
  axes[2][0] = 0.0, axes[2][1] = 0.0, axes[2][2] = 1.0;
}

void tl_wind_profile(int n, const double* t, const double* x, const double* y, const double* z, double at, double w[3]) {
  int lo = 0, hi = n - 1;
  double f;
  if (n <= 0) {
    w[0] = w[1] = w[2] = 0.0;
    return;
  }
  if (at <= t[0] || n == 1) {
    w[0] = x[0], w[1] = y[0], w[2] = z[0];
    return;
  }
  if (at >= t[n - 1]) {
    w[0] = x[n - 1], w[1] = y[n - 1], w[2] = z[n - 1];
    return;
  }
  while (hi - lo > 1) { /* t[lo] <= at < t[hi] */
    int mid = (lo + hi) / 2;
    if (t[mid] <= at) lo = mid;
    else hi = mid;
  }
  f = (at - t[lo]) / (t[hi] - t[lo]);
  w[0] = x[lo] + f * (x[hi] - x[lo]);
  w[1] = y[lo] + f * (y[hi] - y[lo]);
  w[2] = z[lo] + f * (z[hi] - z[lo]);
}
