/* The scenario FMU keeps no state beyond its variables: a sample is a pure function of t. */
#ifndef SCENARIO_MODEL_H
#define SCENARIO_MODEL_H

typedef struct {
  double onset[3]; /* gust onsets (s), from the fractions of the trajectory's duration */
} TlModelState;

#endif
