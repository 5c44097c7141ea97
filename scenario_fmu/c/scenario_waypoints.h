/* The minimum-jerk reference through waypoints, evaluated from its data (scenario_fmu/waypoints.py makes it). */
#ifndef SCENARIO_WAYPOINTS_H
#define SCENARIO_WAYPOINTS_H

#include "tl_platform.h"

/* One axis of the reference at t: the quintic Hermite polynomial of the segment holding t, from the n knots'
   times t[], positions p[], velocities v[] and accelerations a[]; the end knots held at rest outside.
   out = position, velocity, acceleration. */
TL_INTERNAL void tl_waypoints_axis(int n, const double* t, const double* p, const double* v, const double* a, double at, double out[3]);

#endif
