/* An FMI 2.0 co-simulation FMU's step timed alone, in C, for benchmarks/profile_agreement.py: given an instance already
   initialized and its fmi2DoStep and fmi2GetReal, n steps of doStep(t, h) and getReal of its outputs (what the tick
   loop's profile times for an FMU in process; its inputs stay as initialized), each timed with CLOCK_MONOTONIC, the
   clock the profile reads. None of the tick loop's code on the way. */
#define _POSIX_C_SOURCE 200809L
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <time.h>

#if defined(__GNUC__)
#define EXPORT __attribute__((visibility("default")))
#else
#define EXPORT
#endif

typedef int (*step_fn)(void *, double, double, int);
typedef int (*get_fn)(void *, const unsigned int *, size_t, double *);

static int64_t now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

/* Steps from t0; returns the steps done (fewer than n: one failed). */
EXPORT int step_alone(void *component, step_fn do_step, get_fn get_real, double t0, double h, int n,
                      const unsigned int *out_vrs, int n_out, double *out, int64_t *ns) {
    for (int k = 0; k < n; k++) {
        int64_t started = now_ns();
        int failed = do_step(component, t0 + k * h, h, 1) > 1 || (n_out > 0 && get_real(component, out_vrs, (size_t)n_out, out) > 1);
        ns[k] = now_ns() - started;
        if (failed) return k;
    }
    return n;
}
