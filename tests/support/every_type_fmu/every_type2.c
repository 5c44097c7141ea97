/* The FMI 2.0 counterpart of every_type3.c: a parameter p_T, an input u_T and an output y_T of every FMI 2.0 type T
   that carries a number (Real, Integer, Boolean, Enumeration: got and set as an Integer, FMI 2.0's rule), the same
   model (y = u + p * k, the Boolean's and the Enumeration's rules there). Value references per type: p 100 + i,
   u 200 + i, y 300 + i, i the type's index (Real 0, Integer 1, Boolean 2, Enumeration 3). */
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

typedef struct {
  fmi2Real p_Real, u_Real;
  fmi2Integer p_Integer, u_Integer, p_Enum, u_Enum, k;
  fmi2Boolean p_Boolean, u_Boolean;
} Model;

static void starts(Model* m) {
  memset(m, 0, sizeof *m);
  m->p_Enum = 1; m->u_Enum = 1;
}

static fmi2Integer out_enum(const Model* m) { return 1 + (((m->u_Enum + m->p_Enum + m->k) % 3) + 3) % 3; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
  Model* m = (Model*)c;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] == 100) v[i] = m->p_Real;
    else if (vr[i] == 200) v[i] = m->u_Real;
    else if (vr[i] == 300) v[i] = m->u_Real + m->p_Real * m->k;
    else return fmi2Error;
  }
  return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
  Model* m = (Model*)c;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] == 100) m->p_Real = v[i];
    else if (vr[i] == 200) m->u_Real = v[i];
    else return fmi2Error;
  }
  return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
  Model* m = (Model*)c;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] == 101) v[i] = m->p_Integer;
    else if (vr[i] == 201) v[i] = m->u_Integer;
    else if (vr[i] == 301) v[i] = m->u_Integer + m->p_Integer * m->k;
    else if (vr[i] == 103) v[i] = m->p_Enum;
    else if (vr[i] == 203) v[i] = m->u_Enum;
    else if (vr[i] == 303) v[i] = out_enum(m);
    else return fmi2Error;
  }
  return fmi2OK;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
  Model* m = (Model*)c;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] == 101) m->p_Integer = v[i];
    else if (vr[i] == 201) m->u_Integer = v[i];
    else if (vr[i] == 103) m->p_Enum = v[i];
    else if (vr[i] == 203) m->u_Enum = v[i];
    else return fmi2Error;
  }
  return fmi2OK;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
  Model* m = (Model*)c;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] == 102) v[i] = m->p_Boolean;
    else if (vr[i] == 202) v[i] = m->u_Boolean;
    else if (vr[i] == 302) v[i] = (m->u_Boolean != 0) != (m->p_Boolean && (m->k & 1));
    else return fmi2Error;
  }
  return fmi2OK;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
  Model* m = (Model*)c;
  for (size_t i = 0; i < n; i++) {
    if (vr[i] == 102) m->p_Boolean = v[i];
    else if (vr[i] == 202) m->u_Boolean = v[i];
    else return fmi2Error;
  }
  return fmi2OK;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
  (void)c; (void)vr; (void)v;
  return n ? fmi2Error : fmi2OK;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
  (void)c; (void)vr; (void)v;
  return n ? fmi2Error : fmi2OK;
}

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
  (void)c; (void)on; (void)n; (void)cat;
  return fmi2OK;
}
fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String resources,
                              const fmi2CallbackFunctions* functions, fmi2Boolean visible, fmi2Boolean logging) {
  (void)name; (void)guid; (void)resources; (void)functions; (void)visible; (void)logging;
  if (type != fmi2CoSimulation) return NULL;
  Model* m = malloc(sizeof *m);
  if (m != NULL) starts(m);
  return m;
}
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean a, fmi2Real b, fmi2Real d, fmi2Boolean e, fmi2Real f) {
  (void)c; (void)a; (void)b; (void)d; (void)e; (void)f;
  return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { starts((Model*)c); return fmi2OK; }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_set_prior) {
  (void)t; (void)h; (void)no_set_prior;
  ((Model*)c)->k++;
  return fmi2OK;
}
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* v) { (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* v) { (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer* v) { (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* v) {
  (void)c; (void)s;
  *v = fmi2False;
  return fmi2OK;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String* v) { (void)c; (void)s; (void)v; return fmi2Discard; }
fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }

/* what the FMU does not offer (FMPy binds every function of the standard) */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* s) { (void)c; (void)s; return fmi2Error; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t* n) { (void)c; (void)s; (void)n; return fmi2Error; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
  (void)c; (void)s; (void)b; (void)n;
  return fmi2Error;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate* s) {
  (void)c; (void)b; (void)n; (void)s;
  return fmi2Error;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference a[], size_t na,
                                        const fmi2ValueReference b[], size_t nb, const fmi2Real d[], fmi2Real e[]) {
  (void)c; (void)a; (void)na; (void)b; (void)nb; (void)d; (void)e;
  return fmi2Error;
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[],
                                       const fmi2Real v[]) {
  (void)c; (void)vr; (void)n; (void)o; (void)v;
  return fmi2Error;
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[],
                                        fmi2Real v[]) {
  (void)c; (void)vr; (void)n; (void)o; (void)v;
  return fmi2Error;
}
