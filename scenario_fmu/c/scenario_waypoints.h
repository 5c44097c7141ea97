/* The minimum-jerk reference through waypoints, evaluated from its knots (scenario_fmu/waypoints.py makes them),
   and the knot file that carries them into the FMU (docs/test_bench.md, Missions in another FMI tool). */
#ifndef SCENARIO_WAYPOINTS_H
#define SCENARIO_WAYPOINTS_H

#include "tl_platform.h"

#include <stddef.h>

#include "scenario_capacity.h"

/* One axis of the reference at t: the quintic Hermite polynomial of the segment holding t, from the n knots'
   times t[], positions p[], velocities v[] and accelerations a[]; the end knots held at rest outside.
   out = position, velocity, acceleration. */
TL_INTERNAL void tl_waypoints_axis(int n, const double* t, const double* p, const double* v, const double* a, double at, double out[3]);

/* Read a knot file: a header line naming the TL_KNOT_COLUMNS columns (TL_KNOT_HEADER), then one line of as many numbers
   per knot, at most TL_MAX_WAYPOINTS of them; knot[c][i] is column c of knot i. Returns 0 and the count in *n, or
   non-zero with a one-line reason in why (of why_size bytes) naming the line. Not a regular file, a line longer than
   TL_KNOT_LINE or a number that is not one: refused before anything is used. */
TL_INTERNAL int tl_waypoints_load(const char* path, double knot[TL_KNOT_COLUMNS][TL_MAX_WAYPOINTS], int* n, char* why, size_t why_size);

#endif
