/* The formation FMU's state beyond its variables: the law, the integrated references, e_C. */
#ifndef FORMATION_MODEL_H
#define FORMATION_MODEL_H

typedef struct {
  int law;                                /* 0 backstepping, 1 tsid */
  int started;                            /* the references start at the UAVs' first measured state */
  double rho_ref[12], rho_dot_ref[12];    /* x y z psi of sigma, zeta, tau: integrated references */
  double e_C[24];                         /* the integral of e_B (backstepping) */
} TlModelState;

#endif
