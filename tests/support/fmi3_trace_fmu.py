"""A small clocked FMI 3.0 FMU that logs every call it gets, with its arguments and values (hex floats), to hold two
importers' call sequences side by side: the C tick loop's Event Mode and fmi3.py's.

It has what the thesis's FMUs lack: a discrete input (an event when it changes), two clocks of different intervals and
a shift (ticks where no clock is due), an fmi3DoStep that asks for an event (eventHandlingNeeded) every 7th step, and
an fmi3UpdateDiscreteStates that asks for a second update in every 5th event and sets a next event time in every
4th (on a tick where nothing else makes an event: 3 mod 6 on the 10 ms tick). It refuses (fmi3Error) what the
standard forbids: a discrete input set outside Event Mode, a clocked variable set or read while its clock is inactive
(but at initialization), a step at a time other than its own (within 1e-9 s).

    clocks a (20 ms), b (30 ms, shift 10 ms); inputs u_c (Float64), u_d (Int32, discrete), u_a (Float64, clock a),
    b_b (Boolean, clock b); outputs y (Float64), y_a (Float64, clock a), n_b (Int32, clock b), f (Boolean, discrete)
"""

from __future__ import annotations

import inspect
import subprocess
import zipfile
from pathlib import Path

from fmpy.fmi3 import FMU3Slave

IDENTIFIER = "trace"
TICK = 0.01

SOURCE = r"""
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>

#define EXPORT __attribute__((visibility("default")))

typedef void Logger(void *env, int status, const char *category, const char *message);

typedef struct {
    void *env;
    Logger *log;
    double time, y, u_c, u_a;
    int u_d, events, steps, updates;
    bool b_b, f, clock_a, clock_b, in_event, initializing;
} Trace;

static void say(Trace *c, const char *format, ...) {
    char line[256];
    va_list args;
    va_start(args, format);
    vsnprintf(line, sizeof line, format, args);
    va_end(args);
    c->log(c->env, 0, "trace", line);
}

static int refuse(Trace *c, const char *what, unsigned int vr) {
    say(c, "refused: %s %u", what, vr);
    return 3;
}

EXPORT const char *fmi3GetVersion(void) { return "3.0"; }

EXPORT void *fmi3InstantiateCoSimulation(const char *name, const char *token, const char *resources, bool visible,
                                         bool logging_on, bool event_mode_used, bool early_return_allowed,
                                         const unsigned int *required, size_t n_required, void *env, Logger *log,
                                         void *intermediate_update) {
    (void)name; (void)token; (void)resources; (void)visible; (void)logging_on; (void)early_return_allowed;
    (void)required; (void)n_required; (void)intermediate_update;
    if (!event_mode_used) return NULL;
    Trace *c = calloc(1, sizeof(Trace));
    if (c != NULL) {
        c->env = env;
        c->log = log;
    }
    return c;
}

EXPORT void fmi3FreeInstance(void *instance) { free(instance); }

EXPORT int fmi3EnterInitializationMode(void *instance, bool tolerance_defined, double tolerance, double start,
                                       bool stop_defined, double stop) {
    (void)tolerance_defined; (void)tolerance; (void)stop_defined; (void)stop;
    Trace *c = instance;
    c->time = start;
    c->initializing = true;
    return 0;
}

EXPORT int fmi3ExitInitializationMode(void *instance) {
    Trace *c = instance;
    c->initializing = false;
    c->in_event = true;
    say(c, "exitInitializationMode");
    return 0;
}

EXPORT int fmi3EnterEventMode(void *instance) {
    Trace *c = instance;
    c->in_event = true;
    c->updates = 0;
    say(c, "enterEventMode t=%a", c->time);
    return 0;
}

EXPORT int fmi3EnterStepMode(void *instance) {
    Trace *c = instance;
    c->in_event = c->clock_a = c->clock_b = false;
    c->updates = 0;
    say(c, "enterStepMode");
    return 0;
}

EXPORT int fmi3SetClock(void *instance, const unsigned int *vrs, size_t n, const bool *values) {
    Trace *c = instance;
    for (size_t i = 0; i < n; i++) {
        if (!c->in_event) return refuse(c, "setClock outside Event Mode", vrs[i]);
        if (vrs[i] == 1) c->clock_a = values[i];
        else if (vrs[i] == 2) c->clock_b = values[i];
        else return refuse(c, "setClock", vrs[i]);
        say(c, "setClock %u=%d", vrs[i], (int)values[i]);
    }
    return 0;
}

EXPORT int fmi3SetFloat64(void *instance, const unsigned int *vrs, size_t n, const double *values, size_t n_values) {
    Trace *c = instance;
    if (n != n_values) return refuse(c, "setFloat64 lengths", (unsigned int)n);
    for (size_t i = 0; i < n; i++) {
        if (vrs[i] == 10) c->u_c = values[i];
        else if (vrs[i] == 12 && (c->clock_a || c->initializing)) c->u_a = values[i];
        else return refuse(c, "setFloat64", vrs[i]);
        say(c, "setFloat64 %u=%a", vrs[i], values[i]);
    }
    return 0;
}

EXPORT int fmi3SetInt32(void *instance, const unsigned int *vrs, size_t n, const int *values, size_t n_values) {
    Trace *c = instance;
    if (n != n_values) return refuse(c, "setInt32 lengths", (unsigned int)n);
    for (size_t i = 0; i < n; i++) {
        if (vrs[i] == 11 && (c->in_event || c->initializing)) c->u_d = values[i];
        else return refuse(c, "setInt32", vrs[i]);
        say(c, "setInt32 %u=%d", vrs[i], values[i]);
    }
    return 0;
}

EXPORT int fmi3SetBoolean(void *instance, const unsigned int *vrs, size_t n, const bool *values, size_t n_values) {
    Trace *c = instance;
    if (n != n_values) return refuse(c, "setBoolean lengths", (unsigned int)n);
    for (size_t i = 0; i < n; i++) {
        if (vrs[i] == 13 && (c->clock_b || c->initializing)) c->b_b = values[i];
        else return refuse(c, "setBoolean", vrs[i]);
        say(c, "setBoolean %u=%d", vrs[i], (int)values[i]);
    }
    return 0;
}

EXPORT int fmi3GetFloat64(void *instance, const unsigned int *vrs, size_t n, double *values, size_t n_values) {
    Trace *c = instance;
    if (n != n_values) return refuse(c, "getFloat64 lengths", (unsigned int)n);
    for (size_t i = 0; i < n; i++) {
        if (vrs[i] == 0) values[i] = c->time;
        else if (vrs[i] == 20) values[i] = c->y;
        else if (vrs[i] == 21 && (c->clock_a || c->initializing)) values[i] = 2.0 * c->u_a + c->time;
        else return refuse(c, "getFloat64", vrs[i]);
        say(c, "getFloat64 %u=%a", vrs[i], values[i]);
    }
    return 0;
}

EXPORT int fmi3GetInt32(void *instance, const unsigned int *vrs, size_t n, int *values, size_t n_values) {
    Trace *c = instance;
    if (n != n_values) return refuse(c, "getInt32 lengths", (unsigned int)n);
    for (size_t i = 0; i < n; i++) {
        if (vrs[i] == 22 && (c->clock_b || c->initializing)) values[i] = c->u_d + (c->b_b ? 100 : 0) + c->events;
        else return refuse(c, "getInt32", vrs[i]);
        say(c, "getInt32 %u=%d", vrs[i], values[i]);
    }
    return 0;
}

EXPORT int fmi3GetBoolean(void *instance, const unsigned int *vrs, size_t n, bool *values, size_t n_values) {
    Trace *c = instance;
    if (n != n_values) return refuse(c, "getBoolean lengths", (unsigned int)n);
    for (size_t i = 0; i < n; i++) {
        if (vrs[i] == 23) values[i] = c->f;
        else return refuse(c, "getBoolean", vrs[i]);
        say(c, "getBoolean %u=%d", vrs[i], (int)values[i]);
    }
    return 0;
}

EXPORT int fmi3UpdateDiscreteStates(void *instance, bool *need_update, bool *terminate, bool *nominals_changed,
                                    bool *values_changed, bool *next_event_defined, double *next_event_time) {
    Trace *c = instance;
    if (!c->in_event) return refuse(c, "updateDiscreteStates outside Event Mode", 0);
    if (c->updates++ == 0) {
        c->events++;
        c->f = !c->f;
    }
    *need_update = c->events % 5 == 2 && c->updates == 1;
    *terminate = *nominals_changed = *values_changed = false;
    *next_event_defined = c->events % 4 == 1;
    long next = (long)(c->time / 0.01 + 0.5) + 1; /* the next tick 3 (mod 6): no clock due, no input changed there */
    while (next % 6 != 3) next++;
    *next_event_time = (double)next * 0.01;
    say(c, "updateDiscreteStates event %d update %d: need %d, next %d", c->events, c->updates, (int)*need_update,
        (int)*next_event_defined);
    return 0;
}

EXPORT int fmi3DoStep(void *instance, double t, double h, bool no_set_prior, bool *event_needed, bool *terminate,
                      bool *early_return, double *last_time) {
    (void)no_set_prior;
    Trace *c = instance;
    double late = t - c->time;
    if (c->in_event || late > 1e-9 || late < -1e-9) return refuse(c, "doStep", 0);
    c->y += h * (c->u_c + 1.0) + 1e-3 * c->u_d + (c->b_b ? 1e-6 : 0.0);
    c->time = t + h;
    c->steps++;
    *event_needed = c->steps % 7 == 3;
    *terminate = *early_return = false;
    *last_time = c->time;
    say(c, "doStep t=%a h=%a: y=%a, event %d", t, h, c->y, (int)*event_needed);
    return 0;
}

EXPORT int fmi3Terminate(void *instance) { (void)instance; return 0; }

EXPORT int fmi3Reset(void *instance) {
    Trace *c = instance;
    Trace fresh = {0};
    fresh.env = c->env;
    fresh.log = c->log;
    *c = fresh;
    return 0;
}
"""

DESCRIPTION = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="Trace" instantiationToken="{7e57c10c-0000-4000-8000-000000000042}"
    variableNamingConvention="flat">
  <CoSimulation modelIdentifier="trace" canHandleVariableCommunicationStepSize="true" hasEventMode="true"/>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Clock name="a" valueReference="1" causality="input" variability="discrete" intervalVariability="constant"
        intervalDecimal="0.02" shiftDecimal="0"/>
    <Clock name="b" valueReference="2" causality="input" variability="discrete" intervalVariability="constant"
        intervalDecimal="0.03" shiftDecimal="0.01"/>
    <Float64 name="u_c" valueReference="10" causality="input" variability="continuous" start="0"/>
    <Int32 name="u_d" valueReference="11" causality="input" variability="discrete" start="0"/>
    <Float64 name="u_a" valueReference="12" causality="input" variability="discrete" clocks="1" start="0"/>
    <Boolean name="b_b" valueReference="13" causality="input" variability="discrete" clocks="2" start="false"/>
    <Float64 name="y" valueReference="20" causality="output" variability="continuous"/>
    <Float64 name="y_a" valueReference="21" causality="output" variability="discrete" clocks="1"/>
    <Int32 name="n_b" valueReference="22" causality="output" variability="discrete" clocks="2"/>
    <Boolean name="f" valueReference="23" causality="output" variability="discrete"/>
  </ModelVariables>
  <ModelStructure>
    <Output valueReference="20"/>
    <Output valueReference="21"/>
    <Output valueReference="22"/>
    <Output valueReference="23"/>
    <InitialUnknown valueReference="20"/>
    <InitialUnknown valueReference="23"/>
  </ModelStructure>
</fmiModelDescription>
"""


def trace_fmu(folder: Path) -> Path:
    """The FMU, built for this machine (x86_64-linux) into folder. Every fmi3 function FMPy looks up and the FMU does
    not define is a stub that returns fmi3Error."""
    folder = Path(folder)
    defined = {line.split("(")[0].split()[-1].lstrip("*") for line in SOURCE.splitlines() if line.startswith("EXPORT ")}
    stubs = [name for name, _ in inspect.getmembers(FMU3Slave) if name.startswith("fmi3") and name not in defined]
    source = SOURCE + "".join(f"EXPORT int {name}(void) {{ return 3; }}\n" for name in stubs)
    (folder / "trace.c").write_text(source)
    library = folder / f"{IDENTIFIER}.so"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", "-fvisibility=hidden", "-O1",
                    str(folder / "trace.c"), "-o", str(library)], check=True)
    fmu = folder / "Trace.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", DESCRIPTION)
        z.write(library, f"binaries/x86_64-linux/{IDENTIFIER}.so")
    return fmu
