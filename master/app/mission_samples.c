/* A waypoint mission's reference at many times for the feasibility check, by the scenario FMU's own evaluation
 * (scenario_waypoints.c's tl_waypoints_axis, compiled with this file): the reference the FMU will output, without
 * numpy's thirty passes over the samples. */
#include "scenario_waypoints.h"

enum { TL_AXES = 4 }; /* x, y, z, psi */

/* n knots: times t[n], and p, v, a each TL_AXES rows of n (axis by axis); pos, vel, acc: count rows of TL_AXES. */
__attribute__((visibility("default")))
void tl_mission_samples(int n, const double *t, const double *p, const double *v, const double *a, int count,
                        const double *times, double *pos, double *vel, double *acc)
{
    for (int i = 0; i < count; i++) {
        for (int k = 0; k < TL_AXES; k++) {
            double out[3];
            size_t at = (size_t)k * (size_t)n, row = (size_t)i * TL_AXES + (size_t)k;
            tl_waypoints_axis(n, t, p + at, v + at, a + at, times[i], out);
            pos[row] = out[0];
            vel[row] = out[1];
            acc[row] = out[2];
        }
    }
}
