/* A clock that reads the FMU's own time (tests/engine/test_start_time.py): now = the time its outputs belong to (the
   start time after initialization, t + h after doStep(t, h)), tenths = now in whole tenths of a second (a discrete
   output), steps = the steps taken, y = u + now (a feedthrough of its input). */
#include "tl_platform.h"

#include <math.h>

#include "tl_fmu.h"

void tl_model_reset(TlInstance* c) { c->s.model.unused = 0; }

static TlStatus outputs_at(TlInstance* c, double now) {
  c->s.real[TL_REAL_now] = now;
  c->s.integer[TL_INTEGER_tenths] = (int)lround(now * 10.0);
  c->s.real[TL_REAL_y] = c->s.real[TL_REAL_u] + now;
  return TL_OK;
}

/* its time is the start time in Initialization Mode, a step's end after it */
TlStatus tl_model_outputs(TlInstance* c) { return outputs_at(c, c->s.time); }

TlStatus tl_model_initialize(TlInstance* c) {
  c->s.integer[TL_INTEGER_steps] = 0;
  return outputs_at(c, c->s.start_time);
}

TlStatus tl_model_step(TlInstance* c, double t, double h) {
  c->s.integer[TL_INTEGER_steps] += 1;
  return outputs_at(c, t + h);
}
