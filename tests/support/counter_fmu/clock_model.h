/* A clock that reads the FMU's time: the model state (none beyond the variables). */
#ifndef CLOCK_MODEL_H
#define CLOCK_MODEL_H

typedef struct {
  int unused;
} TlModelState;

#endif
