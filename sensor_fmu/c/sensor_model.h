/* The sensor FMU's own state beyond its variables (saved with every FMU state snapshot). */
#ifndef SENSOR_MODEL_H
#define SENSOR_MODEL_H

#define TL_SENSOR_MAX_GROUPS 16
#define TL_SENSOR_MAX_PARAMS 64

typedef struct {
  long ticks[TL_SENSOR_MAX_GROUPS];   /* ticks per sample of each group */
  int gaussian[TL_SENSOR_MAX_GROUPS]; /* 1 gaussian, 0 uniform */
  double params[TL_SENSOR_MAX_PARAMS]; /* the parameter vector pi(x) is evaluated with */
} TlModelState;

#endif
