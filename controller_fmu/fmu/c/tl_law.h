/* The tracking law of the thesis (3.18, Sec. A.3, Sec. B.3.3), shared by the controller FMUs:
   u = sat(u_tr - K [chi; du_(k-d) .. du_(k-1)]), chi = [x - x_tr; integrals of the x, y, z, psi errors].
   x_tr puts the vehicle (or the load) on the reference with every other coordinate at its trim; u_tr is
   the feedforward of the reference, computed by the caller's CasADi-generated function. */
#ifndef TL_LAW_H
#define TL_LAW_H

#include "tl_platform.h"

#define TL_LAW_MAX_NX 20   /* the load's 20 states; the UAV alone has 16 */
#define TL_LAW_MAX_DELAY 2 /* commands in flight a delay-aware gain acts on */

/* u_tr (4) of the reference state x_tr (nx) and accelerations qdd (nx / 2); 0 ok. */
typedef int (*TlFeedforward)(const double* x_tr, const double* qdd, double* u_tr);

typedef struct {
  int nx;                /* states of the vehicle */
  const double* trim_x;  /* nx */
  const double* K;       /* 4 x (nx + 4 + 4 d), row-major */
  int delay;             /* d */
  double Tc;             /* s: the integrals advance by Tc times the error */
  double f_min, f_max, tau_max;
  TlFeedforward feedforward;
} TlLaw;

/* ref: the 11 references x y z, vx vy vz, ax ay az, psi, psi_dot. estimate: nx. integral (4) advances;
   du_sent[i] (4 each) are the deviations of the commands of i + 1 ticks ago (newest first) and shift in the new
   one. u (4): the saturated command. 0 ok, -1 the feedforward failed. */
TL_INTERNAL int tl_law_step(const TlLaw* law, const double* ref, const double* estimate, double* integral,
                double du_sent[][4], double* u);

#endif
