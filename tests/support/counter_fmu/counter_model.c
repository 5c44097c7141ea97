/* A counter that ends the simulation (tests/engine/test_edges.py): count goes up by one a step and x = count * gain,
   y = u (a feedthrough of its input). At count == limit it asks the importer to terminate: FMI 3.0 with
   terminateSimulation from the step that reached it; FMI 2.0 by refusing the next step (fmi2Discard, fmi2Terminated). */
#include "tl_platform.h"

#include "tl_fmu.h"

void tl_model_reset(TlInstance* c) { c->s.model.unused = 0; }

TlStatus tl_model_outputs(TlInstance* c) {
  c->s.real[TL_REAL_x] = c->s.integer[TL_INTEGER_count] * c->s.real[TL_REAL_gain];
  c->s.real[TL_REAL_y] = c->s.real[TL_REAL_u];
  return TL_OK;
}

TlStatus tl_model_initialize(TlInstance* c) {
  c->s.integer[TL_INTEGER_count] = c->s.integer[TL_INTEGER_first];
  return tl_model_outputs(c);
}

TlStatus tl_model_step(TlInstance* c, double t, double h) {
  (void)t;
  (void)h;
#if TL_FMI_VERSION == 2
  if (c->s.integer[TL_INTEGER_count] >= c->s.integer[TL_INTEGER_limit]) {
    c->s.stop_requested = 1;
    return TL_DISCARD;
  }
#endif
  c->s.integer[TL_INTEGER_count] += 1;
  if (c->s.integer[TL_INTEGER_count] >= c->s.integer[TL_INTEGER_limit]) c->s.stop_requested = TL_FMI_VERSION == 3;
  return tl_model_outputs(c);
}
