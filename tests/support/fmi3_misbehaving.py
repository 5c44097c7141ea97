"""Misbehaving FMI 3.0 controllers: our FMI 3.0 controller whose fmi3DoStep, from a given time on, crashes, exits or
hangs, or (the clocked one) whose fmi3UpdateDiscreteStates returns fmi3Error or never settles (discreteStatesNeedUpdate
always true), or (the Scheduled Execution one) whose partitions are refused or return holding a preemption lock, in C
as a foreign FMU would.

The FMU's library is replaced by a small shim of the same name that defines one fmi3 function only and needs the
original library (renamed beside it; linked --no-as-needed, or the linker drops the dependency): every other fmi3
function a host looks up in the shim is found in the original (dlsym searches a library's dependencies), and the
shim's function hands over to the original's (RTLD_NEXT) until the time comes (fmi3UpdateDiscreteStates reads it
from the independent variable, value reference 0). The build record is left out: the master
treats the FMU as foreign.
"""

from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

SHIM = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <signal.h>
#include <stdbool.h>
#include <stdlib.h>
#include <unistd.h>

typedef int DoStep(void *, double, double, bool, bool *, bool *, bool *, double *);

int fmi3DoStep(void *instance, double t, double h, bool no_set_state_prior, bool *event_needed, bool *terminate,
               bool *early_return, double *last_time) {
    if (t >= AT) {
        ACT;
    }
    DoStep *original;
    *(void **)&original = dlsym(RTLD_NEXT, "fmi3DoStep");
    return original(instance, t, h, no_set_state_prior, event_needed, terminate, early_return, last_time);
}
"""

UPDATE_SHIM = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdbool.h>
#include <stddef.h>

typedef int Update(void *, bool *, bool *, bool *, bool *, bool *, double *);
typedef int GetFloat64(void *, const unsigned int *, size_t, double *, size_t);

int fmi3UpdateDiscreteStates(void *instance, bool *need_update, bool *terminate, bool *nominals_changed,
                             bool *values_changed, bool *next_event_defined, double *next_event_time) {
    GetFloat64 *get;
    Update *original;
    *(void **)&get = dlsym(RTLD_NEXT, "fmi3GetFloat64");
    *(void **)&original = dlsym(RTLD_NEXT, "fmi3UpdateDiscreteStates");
    const unsigned int time_vr = 0;
    double t = 0.0;
    get(instance, &time_vr, 1, &t, 1);
    int status = original(instance, need_update, terminate, nominals_changed, values_changed, next_event_defined,
                          next_event_time);
    if (t >= AT) {
        ACT;
    }
    return status;
}
"""

PARTITION_SHIM = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdbool.h>
#include <stddef.h>

typedef void Lock(void);
typedef void *Instantiate(const char *, const char *, const char *, bool, bool, void *, void *, void *, Lock *, Lock *);
typedef int Activate(void *, unsigned int, double);

static Lock *lock_preemption; /* the importer's lock callback, kept to take a lock that is never given back */

void *fmi3InstantiateScheduledExecution(const char *name, const char *token, const char *resources, bool visible,
                                        bool logging, void *environment, void *log, void *clock_update, Lock *lock,
                                        Lock *unlock) {
    Instantiate *original;
    *(void **)&original = dlsym(RTLD_NEXT, "fmi3InstantiateScheduledExecution");
    lock_preemption = lock;
    return original(name, token, resources, visible, logging, environment, log, clock_update, lock, unlock);
}

int fmi3ActivateModelPartition(void *instance, unsigned int clock, double t) {
    Activate *original;
    *(void **)&original = dlsym(RTLD_NEXT, "fmi3ActivateModelPartition");
    int status = original(instance, clock, t);
    if (t >= AT) {
        ACT;
    }
    return status;
}
"""

ACTS = {  # what the shim does in place of the call: (which shim, its act)
    "segfault": (SHIM, "raise(SIGSEGV)"),
    "exit": (SHIM, "exit(3)"),
    "hang": (SHIM, "for (;;) pause()"),
    "update_error": (UPDATE_SHIM, "return 3"),  # fmi3Error
    "unsettled": (UPDATE_SHIM, "*need_update = true"),
    # a Scheduled Execution FMU's partition from then on: refused (fmi3Error), or returning with a lock held
    "activate_error": (PARTITION_SHIM, "return 3"),
    "lock_held": (PARTITION_SHIM, "lock_preemption()"),
}
PLATFORM = "x86_64-linux"


def misbehaving_fmi3(controller: Path, folder: Path, modes, at: float) -> dict[str, Path]:
    """{mode: FMU path} for each mode of ACTS: the FMI 3.0 controller at controller, misbehaving from t >= at."""
    folder = Path(folder)
    with zipfile.ZipFile(controller) as z:
        identifier = next(n for n in z.namelist() if n.startswith(f"binaries/{PLATFORM}/")).rsplit("/", 1)[1][:-3]
        original = z.read(f"binaries/{PLATFORM}/{identifier}.so")
    out = {}
    for mode in modes:
        work = folder / f"shim_{mode}"
        work.mkdir(parents=True, exist_ok=True)
        renamed = f"{identifier}_original.so"
        (work / renamed).write_bytes(original)
        shim, act = ACTS[mode]
        (work / "shim.c").write_text(shim.replace("AT", repr(float(at))).replace("ACT", act))
        subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", "-O1", "-o", str(work / f"{identifier}.so"),
                        str(work / "shim.c"), f"-L{work}", "-Wl,--no-as-needed", f"-l:{renamed}", "-Wl,-rpath,$ORIGIN", "-ldl"], check=True)
        out[mode] = folder / f"bad3_{mode}.fmu"
        with zipfile.ZipFile(controller) as src, zipfile.ZipFile(out[mode], "w", zipfile.ZIP_DEFLATED) as dst:
            for item in src.infolist():
                if item.filename == "resources/build_info.json":
                    continue
                if item.filename == f"binaries/{PLATFORM}/{identifier}.so":
                    dst.writestr(item, (work / f"{identifier}.so").read_bytes())
                    dst.writestr(f"binaries/{PLATFORM}/{renamed}", (work / renamed).read_bytes())
                else:
                    dst.writestr(item, src.read(item.filename))
    return out
