#include "tl_platform.h"
#include "tl_law.h"

#include <string.h>

static const int regulated[4] = {0, 1, 2, 5}; /* x, y, z, psi: steered along the path */

int tl_law_step(const TlLaw* law, const double* ref, const double* estimate, double* integral,
                double du_sent[][4], double* u) {
  const int nx = law->nx, d = law->delay, width = nx + 4 + 4 * d;
  double x_tr[TL_LAW_MAX_NX], qdd[TL_LAW_MAX_NX / 2], chi[TL_LAW_MAX_NX + 4], u_tr[4];
  int i, j, b;
  memcpy(x_tr, law->trim_x, sizeof(double) * nx); /* on the path, the rest at its trim (Sec. 3.2) */
  for (i = 0; i < 3; ++i) x_tr[i] = ref[i];
  x_tr[5] = ref[9];
  for (i = nx / 2; i < nx; ++i) x_tr[i] = 0.0;
  for (i = 0; i < 3; ++i) x_tr[nx / 2 + i] = ref[3 + i];
  x_tr[nx / 2 + 5] = ref[10]; /* psi_dot */
  memset(qdd, 0, sizeof qdd);
  for (i = 0; i < 3; ++i) qdd[i] = ref[6 + i];
  if (law->feedforward(x_tr, qdd, u_tr)) return -1;
  for (i = 0; i < nx; ++i) chi[i] = estimate[i] - x_tr[i];
  for (i = 0; i < 4; ++i) chi[nx + i] = integral[i];
  for (i = 0; i < 4; ++i) {
    double v = u_tr[i];
    for (j = 0; j < nx + 4; ++j) v -= law->K[i * width + j] * chi[j];
    for (b = 0; b < d; ++b) /* block b holds du_(k-d+b), the oldest first */
      for (j = 0; j < 4; ++j) v -= law->K[i * width + nx + 4 + 4 * b + j] * du_sent[d - 1 - b][j];
    u[i] = v;
  }
  for (i = 0; i < 4; ++i) integral[i] += law->Tc * chi[regulated[i]];
  for (i = 0; i < 2; ++i) u[i] = u[i] < law->f_min ? law->f_min : u[i] > law->f_max ? law->f_max : u[i];
  for (i = 2; i < 4; ++i) u[i] = u[i] < -law->tau_max ? -law->tau_max : u[i] > law->tau_max ? law->tau_max : u[i];
  if (d > 0) {
    memmove(du_sent[1], du_sent[0], sizeof(double) * 4 * (TL_LAW_MAX_DELAY - 1));
    for (i = 0; i < 4; ++i) du_sent[0][i] = u[i] - u_tr[i];
  }
  return 0;
}
