/* Quintic Hermite segments (scenario_waypoints.h). On s = (t - t_i) / T in [0, 1], with d the scaled end data
   [p0, T v0, T^2 a0, p1, T v1, T^2 a1], the monomial coefficients are those of waypoints.B_HERMITE. */
#include "tl_platform.h"

#include "scenario_waypoints.h"

void tl_waypoints_axis(int n, const double* t, const double* p, const double* v, const double* a, double at, double out[3]) {
  int lo = 0, hi = n - 1;
  double T, s, dp, m0, m1, a0, a1, c[6];
  if (at < t[0] || at >= t[n - 1]) {
    out[0] = at < t[0] ? p[0] : p[n - 1];
    out[1] = out[2] = 0.0;
    return;
  }
  while (hi - lo > 1) { /* t[lo] <= at < t[hi] */
    int mid = (lo + hi) / 2;
    if (t[mid] <= at) lo = mid;
    else hi = mid;
  }
  T = t[hi] - t[lo];
  s = (at - t[lo]) / T;
  dp = p[hi] - p[lo];
  m0 = T * v[lo], m1 = T * v[hi], a0 = T * T * a[lo], a1 = T * T * a[hi];
  c[0] = p[lo];
  c[1] = m0;
  c[2] = 0.5 * a0;
  c[3] = 10.0 * dp - 6.0 * m0 - 4.0 * m1 - 1.5 * a0 + 0.5 * a1;
  c[4] = -15.0 * dp + 8.0 * m0 + 7.0 * m1 + 1.5 * a0 - a1;
  c[5] = 6.0 * dp - 3.0 * m0 - 3.0 * m1 - 0.5 * a0 + 0.5 * a1;
  out[0] = c[0] + s * (c[1] + s * (c[2] + s * (c[3] + s * (c[4] + s * c[5]))));
  out[1] = (c[1] + s * (2.0 * c[2] + s * (3.0 * c[3] + s * (4.0 * c[4] + s * 5.0 * c[5])))) / T;
  out[2] = (2.0 * c[2] + s * (6.0 * c[3] + s * (12.0 * c[4] + s * 20.0 * c[5]))) / (T * T);
}
