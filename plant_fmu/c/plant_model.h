/* The plant FMU's own state beyond its variables (saved with every FMU state snapshot). */
#ifndef PLANT_MODEL_H
#define PLANT_MODEL_H

typedef struct {
  int stopped;       /* a step diverged: every later step is refused */
  double stopped_at; /* start of that step (s) */
} TlModelState;

#endif
