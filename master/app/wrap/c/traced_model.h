/* A traced Python controller's own state beyond its variables: the attributes its step assigns (saved with every
   FMU state snapshot). */
#ifndef TRACED_MODEL_H
#define TRACED_MODEL_H

#include "traced_layout.h"

typedef struct {
  double state[TL_TRACED_NS_ROOM]; /* the discrete states, in the order of traced_layout.h */
} TlModelState;

#endif
