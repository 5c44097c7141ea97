/* The tracker FMU's state beyond its variables: the integrals of the law. */
#ifndef TRACKER_MODEL_H
#define TRACKER_MODEL_H

#include "tl_law.h"

typedef struct {
  double integral[4];                /* of the x, y, z, psi errors */
  double du_sent[TL_LAW_MAX_DELAY][4]; /* unused: the design is for no loop delay */
} TlModelState;

#endif
