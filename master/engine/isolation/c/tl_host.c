/* The host's side of the shared-memory link (master/engine/native/tl_link.h): in the worker process that loaded an
   isolated FMU, a loop in C that answers the tick loop's steps (set the inputs, doStep, get the outputs) with no Python
   on the way. The worker (worker.py) calls tl_host_serve once the master asked for the link and returns to its pipe
   when the master yields (a state, a reset, a close: the rare requests stay on the pipe) or goes away. FMI 2.0 and
   FMI 3.0 without clocks through the function pointers the worker's loaded FMU gives; an FMU with clocks (Event Mode,
   or Scheduled Execution's partitions) through the kernel's own sequence, on a plan of this one FMU the worker built
   (host_plan.py, tl_loop.c's tl_step_alone). C99, no global state. */
#if !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 200809L
#define _DEFAULT_SOURCE /* syscall(SYS_futex) */
#endif
#include <poll.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <time.h>

#include "tl_codes.h"
#include "tl_link.h"

#if defined(__GNUC__)
#define TL_EXPORT __attribute__((visibility("default")))
#else
#define TL_EXPORT
#endif

typedef void (*any_fn)(void); /* an FMU's function as the worker gives it: cast to its type at the call */
typedef int (*set2_fn)(void *, const unsigned int *, size_t, const void *);
typedef int (*get2_fn)(void *, const unsigned int *, size_t, void *);
typedef int (*step2_fn)(void *, double, double, int);
typedef int (*status2_fn)(void *, int, void *);
typedef int (*set3_fn)(void *, const unsigned int *, size_t, const void *, size_t);
typedef int (*get3_fn)(void *, const unsigned int *, size_t, void *, size_t);
typedef int (*step3_fn)(void *, double, double, bool, bool *, bool *, bool *, double *);

/* What the worker hands the loop (built in worker.py from the master's request, checked there against the model). */
typedef struct {
    unsigned char *base;
    int64_t size;
    int request_fd;       /* the master's request pipe: readable or hung up = the master is gone or wants the pipe */
    uint32_t seq;         /* the request answered last */
    int64_t spin_ns;
    int fmi3;
    void *component;
    step2_fn do_step;
    status2_fn boolean_status, real_status;
    step3_fn do_step3;
    any_fn set[TL_TYPES], get[TL_TYPES];
    int n_groups;
    const int *group_type;
    const int *group_n;
    const unsigned int *const *group_vrs;
    const int64_t *in_offset;
    int n_out[TL_TYPES];
    const unsigned int *out_vrs[TL_TYPES];
    int64_t out_offset;
    bool *booleans;       /* fmi3: room for the most Boolean values of one call */
    int64_t usual_gap_ns; /* the usual time from a reply to the next request (tl_spin_learn): starts at 0 */
    /* an FMU with clocks: the kernel steps it (NULL: the calls above) */
    void *alone;                 /* the kernel's plan of this FMU */
    tl_step_alone_fn step_alone; /* the kernel's tl_step_alone */
    void *const *group_values;   /* the plan's group value arrays, in the groups' order */
    const void *out[TL_TYPES];   /* the plan's output arrays */
} tl_host;

static size_t width(int type) { return type == TL_REAL ? sizeof(double) : sizeof(int); }

static int64_t now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static int master_gone(const tl_host *h) {
    struct pollfd p = {h->request_fd, POLLIN, 0};
    return poll(&p, 1, 0) > 0;
}

/* The next request: spin (tl_spin_budget: longer where the master's next request usually comes within it), then sleep
   on the futex in slices of 100 ms, looking at the master's pipe between two. Returns its sequence number, or the last
   answered one if the master is gone. */
static uint32_t await_request(tl_host *h) {
    uint32_t *request = tl_link_word(h->base, TL_LINK_REQUEST);
    int64_t start = now_ns();
    int64_t spin = tl_spin_budget(h->spin_ns, h->usual_gap_ns), pause = tl_pause_budget(h->usual_gap_ns);
    for (;;) {
        uint32_t v = __atomic_load_n(request, __ATOMIC_ACQUIRE);
        if (v != h->seq) {
            int64_t sent;
            memcpy(&sent, h->base + TL_LINK_SENT, sizeof sent);
            h->usual_gap_ns = tl_spin_learn(h->usual_gap_ns, tl_link_waited(start, sent, now_ns()));
            return v;
        }
        int64_t now = now_ns();
        if (now - start < spin) {
            tl_spin_wait(start, now, pause);
            continue;
        }
        if (master_gone(h)) return h->seq;
        tl_link_sleep(request, v, 100000000);
    }
}

static int set_values(tl_host *h, int type, const unsigned int *vrs, int n, const void *values) {
    if (!h->fmi3) return ((set2_fn)h->set[type])(h->component, vrs, (size_t)n, values);
    if (type != TL_BOOLEAN) return ((set3_fn)h->set[type])(h->component, vrs, (size_t)n, values, (size_t)n);
    const int *ints = values;
    for (int j = 0; j < n; j++) h->booleans[j] = ints[j] != 0;
    return ((set3_fn)h->set[type])(h->component, vrs, (size_t)n, h->booleans, (size_t)n);
}

static int get_values(tl_host *h, int type, const unsigned int *vrs, int n, void *values) {
    if (!h->fmi3) return ((get2_fn)h->get[type])(h->component, vrs, (size_t)n, values);
    if (type != TL_BOOLEAN) return ((get3_fn)h->get[type])(h->component, vrs, (size_t)n, values, (size_t)n);
    int status = ((get3_fn)h->get[type])(h->component, vrs, (size_t)n, h->booleans, (size_t)n);
    int *ints = values;
    for (int j = 0; j < n; j++) ints[j] = h->booleans[j] ? 1 : 0;
    return status;
}

enum { DISCARD = 2, LAST_SUCCESSFUL_TIME = 2, TERMINATED = 3 }; /* fmi2Discard; fmi2StatusKind's values */

/* The outputs (from: per type) into the reply's room. */
static void put_outputs(tl_host *h, const void *const *from) {
    unsigned char *out = h->base + h->out_offset + TL_LINK_HEADER;
    for (int ty = 0; ty < TL_TYPES; ty++) {
        size_t bytes = (size_t)h->n_out[ty] * width(ty);
        if (bytes) memcpy(out, from[ty], bytes);
        out += bytes;
    }
}

/* A step of an FMU with clocks: the inputs into the plan's groups, the kernel's sequence, the outputs. */
static void step_by_kernel(tl_host *h, tl_link_reply *r, int64_t k, double t, double dt) {
    int64_t started = now_ns();
    for (int g = 0; g < h->n_groups; g++)
        memcpy(h->group_values[g], h->base + h->in_offset[g], (size_t)h->group_n[g] * width(h->group_type[g]));
    if (h->step_alone(h->alone, k, t, dt, r) == 0) put_outputs(h, h->out);
    r->host_ns = now_ns() - started;
}

/* One step as the request asks: its inputs, doStep, its outputs, into the reply. */
static void step(tl_host *h, tl_link_reply *r) {
    unsigned char *b = h->base;
    double t, dt;
    int64_t k;
    memcpy(&t, b + TL_LINK_CALL, sizeof t);
    memcpy(&dt, b + TL_LINK_CALL + 8, sizeof dt);
    memcpy(&k, b + TL_LINK_CALL + 24, sizeof k);
    if (h->alone != NULL) {
        step_by_kernel(h, r, k, t, dt);
        return;
    }
    int64_t started = now_ns();
    for (int g = 0; g < h->n_groups; g++) {
        int status = set_values(h, h->group_type[g], h->group_vrs[g], h->group_n[g], b + h->in_offset[g]);
        if (status > 1) {
            r->call = TL_LINK_SET, r->status = status, r->where = g;
            r->host_ns = now_ns() - started;
            return;
        }
    }
    int status;
    if (h->fmi3) {
        bool event = false, terminate = false, early = false;
        double last = t;
        status = h->do_step3(h->component, t, dt, true, &event, &terminate, &early, &last);
        if (status <= 1 && terminate) { /* the master decides whether that ends the run or fails it */
            r->ended = 1;
            r->last_time = early && last < t + dt ? last : t + dt;
            r->status = DISCARD;
        }
    } else {
        status = h->do_step(h->component, t, dt, 1);
        int terminated = 0;
        if (status == DISCARD && h->boolean_status != NULL && h->boolean_status(h->component, TERMINATED, &terminated) <= 1 &&
            terminated) {
            double last = t + dt;
            if (h->real_status == NULL || h->real_status(h->component, LAST_SUCCESSFUL_TIME, &last) > 1) last = t;
            r->ended = 1;
            r->last_time = last < t ? t : last > t + dt ? t + dt : last;
            r->status = DISCARD;
        }
    }
    if (status > 1 && !r->ended) {
        r->call = TL_LINK_DO_STEP, r->status = status;
        r->host_ns = now_ns() - started;
        return;
    }
    if (r->ended) r->call = TL_LINK_DO_STEP;
    unsigned char *out = b + h->out_offset + TL_LINK_HEADER;
    for (int ty = 0; ty < TL_TYPES; ty++) {
        if (h->n_out[ty] == 0) continue;
        status = get_values(h, ty, h->out_vrs[ty], h->n_out[ty], out);
        if (status > 1) {
            r->call = TL_LINK_GET, r->status = status, r->where = ty, r->ended = 0;
            break;
        }
        out += (size_t)h->n_out[ty] * width(ty);
    }
    r->host_ns = now_ns() - started;
}

/* Answer steps until the master yields (returns 0: the worker answers on its pipe) or is gone (returns 1). */
TL_EXPORT int tl_host_serve(tl_host *h);
TL_EXPORT int tl_host_serve(tl_host *h) {
    uint32_t out_bytes = 0;
    for (int ty = 0; ty < TL_TYPES; ty++) out_bytes += (uint32_t)((size_t)h->n_out[ty] * width(ty));
    for (;;) {
        uint32_t seq = await_request(h);
        if (seq == h->seq) return 1;
        h->seq = seq;
        uint32_t op;
        memcpy(&op, h->base + TL_LINK_CALL + 16, sizeof op);
        tl_link_reply r;
        memset(&r, 0, sizeof r);
        r.out_bytes = out_bytes;
        if (op == TL_LINK_STEP) step(h, &r);
        r.sent_ns = now_ns();
        memcpy(h->base + h->out_offset, &r, sizeof r);
        tl_link_publish(tl_link_word(h->base, TL_LINK_REPLY), seq);
        if (op != TL_LINK_STEP) return 0;
    }
}
