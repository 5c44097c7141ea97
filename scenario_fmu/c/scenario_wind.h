/* Wind for the scenario FMU: Dryden turbulence (MIL-F-8785C, low altitude) with its shaping filters
   discretized exactly, a piecewise-linear wind profile, and the drag force of the wind on the load.
   The formulas and their sources: scenario_fmu/wind.py and docs/test_bench.md. */
#ifndef SCENARIO_WIND_H
#define SCENARIO_WIND_H

#include "tl_platform.h"

#include <stdint.h>

#define TL_DRYDEN_STATES 5 /* u: one state; v, w: two each */

typedef struct {
  double sigma[3];  /* intensities of u, v, w (m/s) */
  double length[3]; /* scale lengths (m) */
  double airspeed;  /* the speed V the frozen field passes at (m/s) */
} TlDryden;

/* The exact discretization over one step h, kept while the step stays the same. */
typedef struct {
  double h;        /* the step these are for (0: none yet) */
  double decay[3]; /* e^{-a h} of u, v, w */
  double chol[3][3]; /* u: [0] the noise's standard deviation; v, w: l11, l21, l22 of Q_d = L L' */
} TlDrydenStep;

/* Intensities and scale lengths for a severity (1 light, 2 moderate, 3 severe) at an altitude (m, within the
   low-altitude model's range); airspeed 0 picks the steady wind's speed, or W20 without steady wind. */
TL_INTERNAL void tl_dryden_parameters(int severity, double altitude, double airspeed, const double steady[3], TlDryden* d);

/* The filters' state drawn from their stationary distribution (noise sample 0). */
TL_INTERNAL void tl_dryden_start(const TlDryden* d, uint64_t seed, double x[TL_DRYDEN_STATES]);

/* Advance the state over h with the exact discretization; `sample` (>= 1) indexes the noise draws. */
TL_INTERNAL void tl_dryden_step(const TlDryden* d, uint64_t seed, uint64_t sample, double h, TlDrydenStep* cache, double x[TL_DRYDEN_STATES]);

/* The turbulence velocities u, v, w of a state. */
TL_INTERNAL void tl_dryden_output(const TlDryden* d, const double x[TL_DRYDEN_STATES], double uvw[3]);

/* Inertial directions of u (along the horizontal steady wind, else x), v (horizontal, left of u) and w (up). */
TL_INTERNAL void tl_wind_axes(const double steady[3], double axes[3][3]);

/* The profile's value at t: linear between rows (times increasing), held before the first and after the last. */
TL_INTERNAL void tl_wind_profile(int n, const double* t, const double* x, const double* y, const double* z, double at, double w[3]);

#endif
