/* The scenario FMU's state: the reference is a pure function of t (and of the knots read at initialization, kept
   here so that a restored state needs no file); the turbulence filters carry a state. */
#ifndef SCENARIO_MODEL_H
#define SCENARIO_MODEL_H

#include <stdint.h>

#include "scenario_capacity.h"
#include "scenario_wind.h"

typedef struct {
  double onset[3];                /* gust onsets (s), from the fractions of the trajectory's duration */
  TlDryden dryden;                /* intensities, scale lengths, speed: set at initialization */
  double axes[3][3];              /* inertial directions of u, v, w */
  double turbulence[TL_DRYDEN_STATES]; /* the shaping filters' state at the current time */
  TlDrydenStep step;              /* the filters' discretization for the last step size */
  uint64_t sample;                /* noise draws taken (0: the stationary start) */
  int knots;                      /* knots of the waypoint reference, read from waypoints_file at initialization */
  double knot[TL_KNOT_COLUMNS][TL_MAX_WAYPOINTS]; /* t, then x, vx, ax, y, ..., psi, vpsi, apsi of each knot */
} TlModelState;

#endif
