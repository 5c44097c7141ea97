/* A counter that ends the simulation at a given count: the model state (none beyond the variables). */
#ifndef COUNTER_MODEL_H
#define COUNTER_MODEL_H

typedef struct {
  int unused;
} TlModelState;

#endif
