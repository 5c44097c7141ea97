/* The code both FMI layers share (tl_core.h): one definition of the start values, the set checks with their
   messages and the snapshot format, so an FMI 2.0 and an FMI 3.0 build of a model behave alike. */
#include "tl_platform.h"

#include "tl_core.h"

#include <math.h>
#include <string.h>

#define TL_STATE_MAGIC "TLSTATE1"
#define TL_GUID_LEN 40
#define TL_SERIAL_SIZE (8 + TL_GUID_LEN + sizeof(TlState))

void tl_load_start_values(TlInstance* c) {
  int i;
  for (i = 0; i < TL_N_REAL; ++i) c->s.real[i] = tl_real_start[i];
  for (i = 0; i < TL_N_INTEGER; ++i) c->s.integer[i] = tl_integer_start[i];
  for (i = 0; i < TL_N_BOOLEAN; ++i) c->s.boolean[i] = tl_boolean_start[i] ? fmi2True : fmi2False;
#if TL_N_STRING > 0 /* GCC at -O0 warns about the copy into the placeholder array of an FMU without Strings */
  for (i = 0; i < TL_N_STRING; ++i) {
    strncpy(c->s.string[i], tl_string_start[i], TL_STRING_LEN - 1);
    c->s.string[i][TL_STRING_LEN - 1] = '\0';
  }
#endif
  c->s.time = c->s.start_time = 0.0;
  c->s.stop_time = INFINITY;
  c->s.phase = TL_INSTANTIATED;
  c->s.stop_requested = 0;
  memset(c->s.clock_active, 0, sizeof c->s.clock_active);
  c->s.event_dirty = c->s.event_ran = 0;
  c->s.next_event_time = -1.0;
  tl_model_reset(c);
}

const char* tl_phase_name(int phase) {
  switch (phase) {
    case TL_INSTANTIATED: return "instantiated";
    case TL_INITIALIZATION: return "initialization mode";
    case TL_STEPPING: return "step mode";
    case TL_EVENT: return "event mode";
    case TL_TERMINATED: return "terminated";
    case TL_BROKEN: return "fatal error";
    default: return "error";
  }
}

int tl_may_set(TlInstance* c, const char* call, unsigned char settable, const char* name) {
  if (settable == 2 || (settable == 1 && (c->s.phase == TL_INSTANTIATED || c->s.phase == TL_INITIALIZATION))) return 1;
  tl_log(c, fmi2Error, "%s: cannot set %s: it is %s", call, name,
         settable == 1 ? "a parameter, fixed after initialization" : "an output");
  return 0;
}

int tl_real_refused(TlInstance* c, int index, double value) {
  if (isfinite(value)) return 0;
  tl_log(c, fmi2Error, "non-finite %s %s = %g at t=%.6g s; value refused",
         tl_real_settable[index] == 2 ? "input" : "parameter", tl_real_name[index], value, c->s.time);
  return 1;
}

int tl_string_refused(TlInstance* c, const char* call, int index, const char* value) {
  if (value != NULL && strlen(value) < TL_STRING_LEN) return 0;
  tl_log(c, fmi2Error, "%s: %s must be a string of at most %d characters", call, tl_string_name[index], TL_STRING_LEN - 1);
  return 1;
}

static void guid_field(char field[TL_GUID_LEN]) {
  memset(field, 0, TL_GUID_LEN);
  memcpy(field, TL_GUID, strlen(TL_GUID) < TL_GUID_LEN ? strlen(TL_GUID) : TL_GUID_LEN);
}

size_t tl_serial_size(void) { return TL_SERIAL_SIZE; }

void tl_serialize(const TlState* state, unsigned char* bytes) {
  char guid[TL_GUID_LEN];
  guid_field(guid);
  memset(bytes, 0, TL_SERIAL_SIZE);
  memcpy(bytes, TL_STATE_MAGIC, 8);
  memcpy(bytes + 8, guid, TL_GUID_LEN);
  memcpy(bytes + 8 + TL_GUID_LEN, state, sizeof(TlState));
}

int tl_is_serial_of_this_build(const unsigned char* bytes, size_t size) {
  char guid[TL_GUID_LEN];
  guid_field(guid);
  return bytes != NULL && size == TL_SERIAL_SIZE && memcmp(bytes, TL_STATE_MAGIC, 8) == 0 &&
         memcmp(bytes + 8, guid, TL_GUID_LEN) == 0;
}

void tl_deserialize(const unsigned char* bytes, TlState* state) { memcpy(state, bytes + 8 + TL_GUID_LEN, sizeof(TlState)); }
