/* A waypoint mission's reference at many times for the feasibility check, by the scenario FMU's own evaluation
 * (scenario_waypoints.c's tl_waypoints_axis, compiled with this file): the reference the FMU will output, without
 * numpy's thirty passes over the samples. */
#include "scenario_waypoints.h"

enum { TL_AXES = 4 }; /* x, y, z, psi */

/* n knots: times t[n], and p, v, a each TL_AXES rows of n (axis by axis); out: count rows of 3 TL_AXES, each the
 * position, the velocity and the acceleration of x, y, z, psi at its time (the feasibility check's reference rows: its
 * first 11 columns). */
__attribute__((visibility("default")))
void tl_mission_samples(int n, const double *t, const double *p, const double *v, const double *a, int count,
                        const double *times, double *out)
{
    for (int i = 0; i < count; i++) {
        double *row = out + (size_t)i * 3 * TL_AXES;
        for (int k = 0; k < TL_AXES; k++) {
            double at[3];
            size_t axis = (size_t)k * (size_t)n;
            tl_waypoints_axis(n, t, p + axis, v + axis, a + axis, times[i], at);
            row[k] = at[0];
            row[TL_AXES + k] = at[1];
            row[2 * TL_AXES + k] = at[2];
        }
    }
}
