/* An FMI 3.0 co-simulation FMU with a parameter p_T, an input u_T and an output y_T of every numeric FMI 3.0 type T,
   written for the engine's type tests (tests/support/every_type_fmu). After k steps, computed when read (so the
   output at t = 0 follows an input set in Initialization Mode): y = u + p * k for the numbers, y = u != (p && k odd)
   for the Boolean, y = 1 + (u + p + k) % 3 for the Enumeration (items 1..3; got and set as Int64, FMI 3.0's rule).
   Value references: p 100 + i, u 200 + i, y 300 + i for the type of index i (TYPES' order); then the String (12)
   and the Binary (13): y is p after an even number of steps, u after an odd one (the Binary's first byte + k). */
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"

#define TYPES(X)                                                                                                   \
  X(Float32, fmi3Float32, 0) X(Float64, fmi3Float64, 1) X(Int8, fmi3Int8, 2) X(UInt8, fmi3UInt8, 3)                \
  X(Int16, fmi3Int16, 4) X(UInt16, fmi3UInt16, 5) X(Int32, fmi3Int32, 6) X(UInt32, fmi3UInt32, 7)                  \
  X(Int64, fmi3Int64, 8) X(UInt64, fmi3UInt64, 9) X(Boolean, fmi3Boolean, 10)
#define ENUM 11

typedef struct {
#define FIELDS(N, C, I) C p_##N, u_##N;
  TYPES(FIELDS)
  fmi3Int64 p_Enum, u_Enum;
  fmi3UInt64 k;
  char p_String[64], u_String[64];
  fmi3Byte p_Binary[16], u_Binary[16], y_Binary[16];
  size_t p_BinaryN, u_BinaryN;
} Model;

static void starts(Model* m) {
  memset(m, 0, sizeof *m);
  m->p_Enum = 1; m->u_Enum = 1;
  strcpy(m->p_String, "p");
  strcpy(m->u_String, "u");
}

#define OUT_Float32(m) ((fmi3Float32)(m->u_Float32 + m->p_Float32 * (fmi3Float32)m->k))
#define OUT_Float64(m) (m->u_Float64 + m->p_Float64 * (fmi3Float64)m->k)
#define OUT_INT(m, N, C) ((C)(m->u_##N + m->p_##N * (C)m->k))
#define OUT_Int8(m) OUT_INT(m, Int8, fmi3Int8)
#define OUT_UInt8(m) OUT_INT(m, UInt8, fmi3UInt8)
#define OUT_Int16(m) OUT_INT(m, Int16, fmi3Int16)
#define OUT_UInt16(m) OUT_INT(m, UInt16, fmi3UInt16)
#define OUT_Int32(m) OUT_INT(m, Int32, fmi3Int32)
#define OUT_UInt32(m) OUT_INT(m, UInt32, fmi3UInt32)
#define OUT_Int64(m) OUT_INT(m, Int64, fmi3Int64)
#define OUT_UInt64(m) OUT_INT(m, UInt64, fmi3UInt64)
#define OUT_Boolean(m) ((fmi3Boolean)(m->u_Boolean != (m->p_Boolean && (m->k & 1))))
#define OUT_Enum(m) (1 + (((m->u_Enum + m->p_Enum + (fmi3Int64)m->k) % 3) + 3) % 3)

#define ACCESS(N, C, I)                                                                                             \
  fmi3Status fmi3Get##N(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, C v[], size_t nv) {         \
    Model* m = (Model*)instance;                                                                                    \
    if (nv != n) return fmi3Error;                                                                                  \
    for (size_t i = 0; i < n; i++) {                                                                                \
      if (vr[i] == 100 + I) v[i] = m->p_##N;                                                                        \
      else if (vr[i] == 200 + I) v[i] = m->u_##N;                                                                   \
      else if (vr[i] == 300 + I) v[i] = OUT_##N(m);                                                                 \
      else if (I == 8 && vr[i] == 100 + ENUM) v[i] = (C)m->p_Enum;                                                  \
      else if (I == 8 && vr[i] == 200 + ENUM) v[i] = (C)m->u_Enum;                                                  \
      else if (I == 8 && vr[i] == 300 + ENUM) v[i] = (C)OUT_Enum(m);                                                \
      else return fmi3Error;                                                                                        \
    }                                                                                                               \
    return fmi3OK;                                                                                                  \
  }                                                                                                                 \
  fmi3Status fmi3Set##N(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const C v[], size_t nv) {   \
    Model* m = (Model*)instance;                                                                                    \
    if (nv != n) return fmi3Error;                                                                                  \
    for (size_t i = 0; i < n; i++) {                                                                                \
      if (vr[i] == 100 + I) m->p_##N = v[i];                                                                        \
      else if (vr[i] == 200 + I) m->u_##N = v[i];                                                                   \
      else if (I == 8 && vr[i] == 100 + ENUM) m->p_Enum = (fmi3Int64)v[i];                                          \
      else if (I == 8 && vr[i] == 200 + ENUM) m->u_Enum = (fmi3Int64)v[i];                                          \
      else return fmi3Error;                                                                                        \
    }                                                                                                               \
    return fmi3OK;                                                                                                  \
  }
TYPES(ACCESS)

const char* fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance i, fmi3Boolean on, size_t n, const fmi3String c[]) {
  (void)i; (void)on; (void)n; (void)c;
  return fmi3OK;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
                                         fmi3Boolean logging, fmi3Boolean event_mode, fmi3Boolean early_return,
                                         const fmi3ValueReference required[], size_t n_required,
                                         fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
                                         fmi3IntermediateUpdateCallback update) {
  (void)name; (void)token; (void)resources; (void)visible; (void)logging; (void)event_mode; (void)early_return;
  (void)required; (void)n_required; (void)env; (void)log; (void)update;
  Model* m = malloc(sizeof *m);
  if (m != NULL) starts(m);
  return m;
}
fmi3Instance fmi3InstantiateModelExchange(fmi3String a, fmi3String b, fmi3String c, fmi3Boolean d, fmi3Boolean e,
                                          fmi3InstanceEnvironment f, fmi3LogMessageCallback g) {
  (void)a; (void)b; (void)c; (void)d; (void)e; (void)f; (void)g;
  return NULL;
}
void fmi3FreeInstance(fmi3Instance instance) { free(instance); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance i, fmi3Boolean a, fmi3Float64 b, fmi3Float64 c, fmi3Boolean d,
                                       fmi3Float64 e) {
  (void)i; (void)a; (void)b; (void)c; (void)d; (void)e;
  return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance i) { (void)i; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance i) { (void)i; return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance i) { starts((Model*)i); return fmi3OK; }
fmi3Status fmi3EnterEventMode(fmi3Instance i) { (void)i; return fmi3Error; }
fmi3Status fmi3EnterStepMode(fmi3Instance i) { (void)i; return fmi3Error; }
fmi3Status fmi3SetClock(fmi3Instance i, const fmi3ValueReference vr[], size_t n, const fmi3Clock v[]) {
  (void)i; (void)vr; (void)n; (void)v;
  return fmi3Error;
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance i, fmi3Boolean* a, fmi3Boolean* b, fmi3Boolean* c, fmi3Boolean* d,
                                    fmi3Boolean* e, fmi3Float64* f) {
  (void)i; (void)a; (void)b; (void)c; (void)d; (void)e; (void)f;
  return fmi3Error;
}
fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 h, fmi3Boolean no_set_prior,
                      fmi3Boolean* event_needed, fmi3Boolean* terminate, fmi3Boolean* early_return,
                      fmi3Float64* last_successful_time) {
  (void)no_set_prior;
  ((Model*)instance)->k++;
  *event_needed = fmi3False;
  *terminate = fmi3False;
  *early_return = fmi3False;
  *last_successful_time = t + h;
  return fmi3OK;
}

static void copy_text(char* to, fmi3String from) {
  strncpy(to, from != NULL ? from : "", 63);
  to[63] = 0;
}

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, fmi3String v[], size_t nv) {
  Model* m = (Model*)instance;
  if (nv != n) return fmi3Error;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] == 112) v[i] = m->p_String;
    else if (vr[i] == 212) v[i] = m->u_String;
    else if (vr[i] == 312) v[i] = (m->k & 1) ? m->u_String : m->p_String;
    else return fmi3Error;
  }
  return fmi3OK;
}
fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const fmi3String v[], size_t nv) {
  Model* m = (Model*)instance;
  if (nv != n) return fmi3Error;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] == 112) copy_text(m->p_String, v[i]);
    else if (vr[i] == 212) copy_text(m->u_String, v[i]);
    else return fmi3Error;
  }
  return fmi3OK;
}
fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, size_t sizes[],
                         fmi3Binary v[], size_t nv) {
  Model* m = (Model*)instance;
  if (nv != n) return fmi3Error;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] == 113) { v[i] = m->p_Binary; sizes[i] = m->p_BinaryN; }
    else if (vr[i] == 213) { v[i] = m->u_Binary; sizes[i] = m->u_BinaryN; }
    else if (vr[i] == 313) {
      const fmi3Byte* from = (m->k & 1) ? m->u_Binary : m->p_Binary;
      sizes[i] = (m->k & 1) ? m->u_BinaryN : m->p_BinaryN;
      memcpy(m->y_Binary, from, sizes[i]);
      if (sizes[i] > 0) m->y_Binary[0] = (fmi3Byte)(m->y_Binary[0] + m->k);
      v[i] = m->y_Binary;
    } else return fmi3Error;
  }
  return fmi3OK;
}
fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t n, const size_t sizes[],
                         const fmi3Binary v[], size_t nv) {
  Model* m = (Model*)instance;
  if (nv != n) return fmi3Error;
  for (size_t i = 0; i < n; i++) {
    if (sizes[i] > 16) return fmi3Error;
    if (vr[i] == 113) { memcpy(m->p_Binary, v[i], sizes[i]); m->p_BinaryN = sizes[i]; }
    else if (vr[i] == 213) { memcpy(m->u_Binary, v[i], sizes[i]); m->u_BinaryN = sizes[i]; }
    else return fmi3Error;
  }
  return fmi3OK;
}
