/* What the FMI 2.0 and FMI 3.0 layers share beyond the hooks: the instance's start values, the checks of a
   value about to be set, the phase names for messages, and the serialized form of a state snapshot. */
#ifndef TL_CORE_H
#define TL_CORE_H

#include <stddef.h>

#include "tl_fmu.h"

/* Start values into the variables, time 0, phase instantiated, then the model's reset hook. */
TL_INTERNAL void tl_load_start_values(TlInstance* c);

TL_INTERNAL const char* tl_phase_name(int phase);

/* May the variable be set now (settable: 0 output, 1 parameter, 2 input)? Logs why not. */
TL_INTERNAL int tl_may_set(TlInstance* c, const char* call, unsigned char settable, const char* name);

/* Is this value refused for Real variable index (non-finite), or for String index (too long)? Logs why. */
TL_INTERNAL int tl_real_refused(TlInstance* c, int index, double value);
TL_INTERNAL int tl_string_refused(TlInstance* c, const char* call, int index, const char* value);

/* The serialized snapshot: magic, format version, the build's GUID (instantiation token), then the TlState bytes. */
TL_INTERNAL size_t tl_serial_size(void);
TL_INTERNAL void tl_serialize(const TlState* state, unsigned char* bytes);
TL_INTERNAL int tl_is_serial_of_this_build(const unsigned char* bytes, size_t size); /* 1 if deserializable here */
TL_INTERNAL void tl_deserialize(const unsigned char* bytes, TlState* state);

#endif
