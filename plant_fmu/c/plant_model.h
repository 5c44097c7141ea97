/* The plant FMU's own state beyond its variables (saved with every FMU state snapshot). */
#ifndef PLANT_MODEL_H
#define PLANT_MODEL_H

typedef struct {
  int stopped;       /* a step diverged: every later step is refused */
  double stopped_at; /* start of that step (s) */
  int stuck[2];      /* the tilt joints held at the last step: a joint that becomes stuck is stopped first */
} TlModelState;

#endif
