/* The controller FMU's own state beyond its variables: the law's memory and the estimators. */
#ifndef CONTROLLER_MODEL_H
#define CONTROLLER_MODEL_H

#include <stddef.h>

#include "tl_lkf.h"
#include "tl_zse.h"

typedef struct {
  int controller; /* 0 dlqr, 1 mixed */
  int estimator;  /* 0 none, 1 lkf, 2 zse */
  int reduction;  /* TL_REDUCE_* */
  int delay;      /* loop_delay_ticks: the design's transport delay d */
  long k;         /* ticks done */
  double integral[4];        /* of the x, y, z, psi errors */
  double u_sent[TL_MAX_DELAY + 1][4]; /* the commands of the last d + 1 ticks, newest first */
  double du_sent[TL_MAX_DELAY][4];    /* their deviations from the feedforward of their tick, newest first */
  double reference_start[3]; /* the reference at the first tick (the ZSE's initial box is centred there) */
  double estimate[TL_NX], disturbance[3];
  TlLkf lkf;
  TlZse zse;
#if defined(TL_SCHEDULED) && TL_SCHEDULED
  /* Scheduled Execution: what the correction partitions latched for a law instant, one slot per instant parity (a
     correction of the next instant that preempts the law writes the other slot); shared, under the importer's lock */
  double latched_meas[2][TL_NY_ZSE]; /* the ZSE's measurements, pi order */
  int latched_new[2][TL_N_ZSE_GROUPS]; /* each ZSE group's flag as its correction took it */
  double latched_q[2][TL_NY_LKF];    /* the LKF's q */
#endif
} TlModelState;

/* Left out of Event Mode's copy for a rerun (tl_fmu.h): the ZSE's two generator buffers. A step reads the current one
   and writes only the other (tl_zse.h); its initialization writes them from X0 alone. */
#define TL_MODEL_EVENT_UNSAVED_OFFSET (offsetof(TlModelState, zse) + offsetof(TlZse, G))
#define TL_MODEL_EVENT_UNSAVED_SIZE sizeof(((TlModelState*)0)->zse.G)

#endif
