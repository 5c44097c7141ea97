/* The engine's tick loop: see tl_loop.h. The arithmetic is copies only, but for the times t_k = t0 + k * tick, computed as
   the Python engine computes them, a clocked FMU's test of its next event time (as fmi3.py's), and the faults', operation for operation those of faults/apply.py (with
   -ffp-contract=off, so the same roundings). */
#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 200809L
#define _DEFAULT_SOURCE /* syscall(SYS_futex) for the link */
#endif
#include "tl_loop.h"

#include <math.h>
#include <stddef.h>
#include <string.h>
#include <time.h>
#if defined(__linux__)
#include <poll.h>
#endif

#include "tl_link.h"

#if defined(__GNUC__)
#define TL_EXPORT __attribute__((visibility("default")))
#else
#define TL_EXPORT
#endif

static size_t width(int type) { return type == TL_REAL ? sizeof(double) : sizeof(int); }

enum { TL_DISCARD = 2, TL_LAST_SUCCESSFUL_TIME = 2, TL_TERMINATED = 3 }; /* fmi2Discard; fmi2StatusKind's values */

TL_EXPORT int64_t tl_monotonic_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

/* The profile's clock: wall time, or (profile 2) the calling thread's CPU time. */
static int64_t profile_ns(int profile) {
#if defined(CLOCK_THREAD_CPUTIME_ID)
    if (profile == TL_PROFILE_CPU) {
        struct timespec ts;
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
        return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
    }
#endif
    (void)profile;
    return tl_monotonic_ns();
}

/* A time into a profile histogram: bucket e S + s for ns in [2^(e-1) (1 + s / S), 2^(e-1) (1 + (s + 1) / S)), S buckets
   an octave,
   with ns = m 2^e, m in [0.5, 1) (frexp; no allocation, a few ns). profile.py reads the buckets back the same way. */
#define TL_PROFILE_SUB (1 << TL_PROFILE_OCTAVE_BITS)
static void profile_add(int64_t *histogram, int64_t *fastest, int64_t *slowest, int64_t ns) {
    if (ns < *fastest) *fastest = ns;
    if (ns > *slowest) *slowest = ns;
    if (histogram == NULL) return;
    int e = 0;
    double m = frexp(ns > 0 ? (double)ns : 1.0, &e);
    int b = e * TL_PROFILE_SUB + (int)((m - 0.5) * 2.0 * TL_PROFILE_SUB);
    histogram[b < 0 ? 0 : b >= TL_PROFILE_BUCKETS ? TL_PROFILE_BUCKETS - 1 : b]++;
}

static void sleep_until(int64_t ns) {
#if defined(CLOCK_MONOTONIC) && !defined(__APPLE__) && !defined(_WIN32)
    struct timespec ts;
    ts.tv_sec = (time_t)(ns / 1000000000);
    ts.tv_nsec = (long)(ns % 1000000000);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) != 0) {
    }
#else
    while (tl_monotonic_ns() < ns) {
    }
#endif
}

TL_EXPORT void tl_store_history(tl_plan *plan, int64_t j) {
    if (plan->slots <= 0) return;
    int64_t slot = j % plan->slots;
    for (int i = 0; i < plan->n_instances; i++) {
        tl_instance *in = &plan->instances[i];
        for (int t = 0; t < TL_TYPES; t++) {
            if (in->n_out[t] == 0) continue;
            size_t bytes = (size_t)in->n_out[t] * width(t);
            memcpy((char *)in->history[t] + (size_t)slot * bytes, in->out[t], bytes);
        }
    }
}

/* The source values a group reads: its source's current outputs, or the delay line d ticks back. */
static const void *group_source(const tl_plan *plan, const tl_group *g, int64_t k) {
    const tl_instance *src = &plan->instances[g->source];
    if (g->delay == 0) return src->out[g->source_type];
    int64_t j = k + 1 - g->delay; /* the entry holding the values after tick k - d */
    if (j < 0) j = 0;
    size_t bytes = (size_t)src->n_out[g->source_type] * width(g->source_type);
    return (const char *)src->history[g->source_type] + (size_t)(j % plan->slots) * bytes;
}

/* The group's values from its source's (src: of the group's source_type). The one conversion between types a
   connection makes (connections.CONVERSIONS): whole numbers into doubles, exact (every int is a double). */
static void gather(const tl_group *g, const void *src) {
    if (g->type == TL_REAL && g->source_type == TL_INTEGER) {
        const int *s = (const int *)src;
        double *d = (double *)g->values;
        for (int i = 0; i < g->n; i++) d[i] = (double)s[g->src_index[i]];
    } else if (g->type == TL_REAL) {
        const double *s = (const double *)src;
        double *d = (double *)g->values;
        for (int i = 0; i < g->n; i++) d[i] = s[g->src_index[i]];
    } else {
        const int *s = (const int *)src;
        int *d = (int *)g->values;
        for (int i = 0; i < g->n; i++) d[i] = s[g->src_index[i]];
    }
}

static void fail(tl_plan *plan, enum tl_error_kind kind, int instance, int status, int group, int type, double t) {
    plan->error_kind = kind;
    plan->error_instance = instance;
    plan->error_status = status;
    plan->error_group = group;
    plan->error_type = type;
    plan->error_time = t;
}

static void record(tl_plan *plan, int i, int64_t k, double when) {
    tl_instance *in = &plan->instances[i];
    int64_t row = plan->rows[i]++;
    int64_t r = plan->records++;
    plan->record_instance[r] = i;
    plan->record_tick[r] = k;
    plan->record_time[r] = when;
    plan->record_row[r] = row;
    for (int t = 0; t < TL_TYPES; t++) {
        if (in->n_out[t] == 0 || in->record[t] == NULL) continue;
        size_t bytes = (size_t)in->n_out[t] * width(t);
        memcpy((char *)in->record[t] + (size_t)row * bytes, in->out[t], bytes);
    }
}

/* The value lag ticks before (the oldest recorded if there are fewer), as faults/apply.py reads its history. */
static double history_back(const tl_fault *q, int64_t lag) {
    if (lag > q->history_count - 1) lag = q->history_count - 1;
    int64_t slot = (q->history_next - 1 - lag) % q->history_capacity;
    return q->history[slot < 0 ? slot + q->history_capacity : slot];
}

static void apply_faults(tl_plan *plan, int i, int side, double t) {
    for (int f = 0; f < plan->n_faults; f++) { /* the true values first: a delay reads them, not another fault's */
        tl_fault *q = &plan->faults[f];
        if (q->instance != i || q->side != side || q->history == NULL) continue;
        q->history[q->history_next] = ((double *)q->array)[q->index];
        q->history_next = (q->history_next + 1) % q->history_capacity;
        if (q->history_count < q->history_capacity) q->history_count++;
    }
    for (int f = 0; f < plan->n_faults; f++) {
        tl_fault *q = &plan->faults[f];
        if (q->instance != i || q->side != side) continue;
        int on = q->start <= t + 1e-9 && t + 1e-9 < q->end; /* as faults/schedule.py Fault.active */
        if (q->reports && on != plan->fault_on[q->fault]) {
            plan->fault_on[q->fault] = (int8_t)on;
            if (plan->events < plan->event_capacity) {
                int64_t e = plan->events++;
                plan->event_record[e] = plan->records;
                plan->event_fault[e] = q->fault;
                plan->event_start[e] = (int8_t)on;
                plan->event_time[e] = t;
            }
        }
        if (!on) continue;
        if (q->type != TL_REAL) { /* Integer and Boolean targets take an override only (checked before the run) */
            ((int *)q->array)[q->index] = (int)q->value;
            continue;
        }
        double *x = &((double *)q->array)[q->index];
        switch (q->action) {
        case TL_OVERRIDE: *x = q->value; break;
        case TL_BIAS: *x = *x + q->value; break;
        case TL_SCALE: *x = *x * q->value; break;
        case TL_RAMP: *x = *x + q->value * (t - q->start); break;
        case TL_CLAMP: { /* min(max(x, lo), hi) as Python's max and min pick */
            double m = q->value > *x ? q->value : *x;
            *x = q->high < m ? q->high : m;
            break;
        }
        case TL_HOLD:
            if (!q->holding) {
                q->holding = 1;
                q->held = *x;
            }
            *x = q->held;
            break;
        case TL_DELAY: *x = history_back(q, (int64_t)q->value); break;
        case TL_DROPOUT: /* the sample the consumer had before the fault's first tick, as faults/apply.py keeps it */
            if (!q->holding) {
                q->holding = 1;
                q->held = q->history_count > 1 ? history_back(q, 1) : *x;
            }
            *x = q->held;
            break;
#ifdef TL_DRAWS
        case TL_NOISE: /* x + sigma N(0, 1) of default_rng([seed, fault, tick]), as faults/draw.py draws it */
            *x = *x + q->value * tl_draw_normal(q->entropy, q->n_entropy, (uint64_t)nearbyint(t / plan->tick));
            break;
        case TL_JITTER: /* 0..n ticks back, n drawn from default_rng([seed, fault, tick]).integers(0, n + 1) */
            *x = history_back(q, (int64_t)tl_draw_bounded(q->entropy, q->n_entropy, (uint64_t)nearbyint(t / plan->tick),
                                                          (uint64_t)q->value));
            break;
#endif
        default: break;
        }
    }
}

/* FMI 3.0 sets and gets: the values' length passed; Booleans through the instance's bool buffer (int in the arrays). */
static int set3(tl_instance *in, int type, const unsigned int *vrs, int n, const void *values) {
    if (type != TL_BOOLEAN) return in->set3[type](in->component, vrs, (size_t)n, values, (size_t)n);
    const int *ints = values;
    for (int j = 0; j < n; j++) in->booleans[j] = ints[j] != 0;
    return in->set3[type](in->component, vrs, (size_t)n, in->booleans, (size_t)n);
}

static int get3(tl_instance *in, int type, const unsigned int *vrs, int n, void *values) {
    if (type != TL_BOOLEAN) return in->get3[type](in->component, vrs, (size_t)n, values, (size_t)n);
    int status = in->get3[type](in->component, vrs, (size_t)n, in->booleans, (size_t)n);
    int *ints = values;
    for (int j = 0; j < n; j++) ints[j] = in->booleans[j] ? 1 : 0;
    return status;
}

/* ---- a clocked FMU's Event Mode (tl_clocks) ---------------------------------------------------------------- */
static size_t fmu_width(int type) { return type == TL_REAL ? sizeof(double) : type == TL_INTEGER ? sizeof(int) : sizeof(bool); }

/* The part's values from its group's (the kernel's types) into its buffer (the FMU's). */
static void stage(const tl_instance *in, tl_part *p) {
    const tl_group *g = &in->groups[p->group];
    if (p->whole && g->type != TL_BOOLEAN) {
        memcpy(p->buffer, g->values, (size_t)p->n * width(g->type));
    } else if (g->type == TL_REAL) {
        const double *s = g->values;
        double *d = p->buffer;
        for (int j = 0; j < p->n; j++) d[j] = s[p->index[j]];
    } else if (g->type == TL_INTEGER) {
        const int *s = g->values;
        int *d = p->buffer;
        for (int j = 0; j < p->n; j++) d[j] = s[p->index[j]];
    } else {
        const int *s = g->values;
        bool *d = p->buffer;
        for (int j = 0; j < p->n; j++) d[j] = s[p->index[j]] != 0;
    }
}

/* A discrete part whose values differ from those last set (== per value: -0.0 equals 0.0, a NaN differs). */
static int changed(const tl_instance *in, const tl_part *p) {
    if (!p->has_applied) return 1;
    int type = in->groups[p->group].type;
    for (int j = 0; j < p->n; j++) {
        int same = type == TL_REAL ? ((const double *)p->buffer)[j] == ((const double *)p->applied)[j]
                 : type == TL_INTEGER ? ((const int *)p->buffer)[j] == ((const int *)p->applied)[j]
                             : ((const bool *)p->buffer)[j] == ((const bool *)p->applied)[j];
        if (!same) return 1;
    }
    return 0;
}

static int is_due(const tl_clocks *c, int n_due, int clock) {
    for (int d = 0; d < n_due; d++)
        if (c->due[d] == clock) return 1;
    return 0;
}

/* Set one part. Returns 0, or stops the run. */
static int set_part(tl_plan *plan, int i, tl_part *p, double t) {
    tl_instance *in = &plan->instances[i];
    int type = in->groups[p->group].type;
    int status = in->set3[type](in->component, p->vrs, (size_t)p->n, p->buffer, (size_t)p->n);
    if (status > 1) {
        fail(plan, TL_ERROR_SET, i, status, p->group, type, t);
        return 1;
    }
    if (p->kind == TL_DISCRETE) {
        memcpy(p->applied, p->buffer, (size_t)p->n * fmu_width(type));
        p->has_applied = 1;
    }
    return 0;
}

/* Set the parts of the instance whose kind is selected: unclocked (continuous; discrete too with discrete set), or
   clocked by a due clock. Returns 0, or stops the run. */
static int set_parts(tl_plan *plan, int i, double t, int discrete, int clocked, int n_due) {
    tl_clocks *c = plan->instances[i].clocks;
    for (int q = 0; q < c->n_parts; q++) {
        tl_part *p = &c->parts[q];
        int take = p->kind >= 0 ? clocked && is_due(c, n_due, p->kind)
                                : !clocked && (p->kind == TL_CONTINUOUS || discrete);
        if (take && set_part(plan, i, p, t) != 0) return 1;
    }
    return 0;
}

/* The read's buffer (the FMU's types) into the instance's outputs (the kernel's). */
static void scatter(tl_instance *in, const tl_read *r) {
    if (r->whole && r->type != TL_BOOLEAN) { /* fmi3Float64 is a double, fmi3Int32 an int here: the same bytes */
        memcpy(in->out[r->type], r->buffer, (size_t)r->n * width(r->type));
    } else if (r->type == TL_REAL) {
        const double *s = r->buffer;
        double *d = in->out[0];
        for (int j = 0; j < r->n; j++) d[r->index[j]] = s[j];
    } else if (r->type == TL_INTEGER) {
        const int *s = r->buffer;
        int *d = in->out[1];
        for (int j = 0; j < r->n; j++) d[r->index[j]] = s[j];
    } else {
        const bool *s = r->buffer;
        int *d = in->out[2];
        for (int j = 0; j < r->n; j++) d[r->index[j]] = s[j] ? 1 : 0;
    }
}

/* Get the outputs of one clock (-1: of none) into the outputs. Returns 0, or stops the run. */
static int read_clock(tl_plan *plan, int i, int clock, double t) {
    tl_instance *in = &plan->instances[i];
    tl_clocks *c = in->clocks;
    for (int q = c->read_first[clock + 1]; q < c->read_first[clock + 2]; q++) {
        tl_read *r = &c->reads[q];
        int status = in->get3[r->type](in->component, r->vrs, (size_t)r->n, r->buffer, (size_t)r->n);
        if (status > 1) {
            if (clock < 0) fail(plan, TL_ERROR_GET, i, status, -1, r->type, t);
            else fail(plan, TL_ERROR_GET_CLOCKED, i, status, clock, r->type, t);
            return 1;
        }
        scatter(in, r);
    }
    return 0;
}

/* A clocked FMU's step at tick k, before any call: its inputs staged, the clocks due (into c->due, their number into
   *n_due). Returns whether the step is an event. */
static int clocked_event(tl_instance *in, int64_t k, double t, double h, int *n_due) {
    tl_clocks *c = in->clocks;
    for (int q = 0; q < c->n_parts; q++) stage(in, &c->parts[q]);
    *n_due = 0;
    for (int j = 0; j < c->n_clocks; j++) {
        if (k >= c->shift[j] && (k - c->shift[j]) % c->interval[j] == 0) {
            c->due[*n_due] = j;
            c->due_vrs[(*n_due)++] = c->clock_vrs[j];
        }
    }
    int event = c->in_event || *n_due > 0 || c->event_asked || (c->next_event_defined && t >= c->next_event - 1e-9 * h);
    for (int q = 0; q < c->n_parts && !event; q++)
        if (c->parts[q].kind == TL_DISCRETE && changed(in, &c->parts[q])) event = 1;
    return event;
}

/* A clocked FMU's inputs before its step at tick k: in an Event Mode if the step is an event (the header's sequence),
   else the continuous ones alone. Returns 0, or stops the run. */
static int clocked_inputs(tl_plan *plan, int i, int64_t k, double t, int event, int n_due) {
    tl_instance *in = &plan->instances[i];
    tl_clocks *c = in->clocks;
    if (!event) return set_parts(plan, i, t, 0, 0, 0);
    c->event_asked = 0;
    int status;
    if (!c->in_event && (status = c->enter_event_mode(in->component)) > 1) {
        fail(plan, TL_ERROR_ENTER_EVENT_MODE, i, status, -1, -1, t);
        return 1;
    }
    if (set_parts(plan, i, t, 1, 0, 0) != 0) return 1;
    if (n_due > 0) {
        if ((status = c->set_clock(in->component, c->due_vrs, (size_t)n_due, c->due_on)) > 1) {
            fail(plan, TL_ERROR_SET_CLOCK, i, status, -1, -1, t);
            return 1;
        }
        if (set_parts(plan, i, t, 1, 1, n_due) != 0) return 1;
        for (int d = 0; d < n_due; d++) {
            if (c->activations < c->activation_capacity) {
                c->activation_clock[c->activations] = c->due[d];
                c->activation_tick[c->activations++] = k;
            }
        }
        /* before fmi3UpdateDiscreteStates: it deactivates the clocks, and a clocked variable is accessible only while
           its clock is active */
        for (int d = 0; d < n_due; d++)
            if (read_clock(plan, i, c->due[d], t) != 0) return 1;
    }
    bool need = false, terminate = false, nominals = false, values = false, defined = false;
    double next = 0.0;
    int settled = 0;
    for (int it = 0; it < c->max_iterations && !settled; it++) {
        status = c->update_discrete_states(in->component, &need, &terminate, &nominals, &values, &defined, &next);
        if (status > 1) {
            fail(plan, TL_ERROR_UPDATE_DISCRETE_STATES, i, status, -1, -1, t);
            return 1;
        }
        if (terminate) {
            fail(plan, TL_ERROR_TERMINATED_IN_EVENT, i, status, -1, -1, t);
            return 1;
        }
        settled = !need;
    }
    if (!settled) {
        fail(plan, TL_ERROR_UNSETTLED, i, 0, -1, -1, t);
        return 1;
    }
    c->next_event_defined = defined;
    c->next_event = next;
    if ((status = c->enter_step_mode(in->component)) > 1) {
        fail(plan, TL_ERROR_ENTER_STEP_MODE, i, status, -1, -1, t);
        return 1;
    }
    c->in_event = 0;
    return 0;
}

/* ---- a Scheduled Execution FMU's partitions (tl_clocks with activate) ---------------------------------------- */
/* Its step at tick k, after clocked_event staged the inputs and found the n_due clocks due: the inputs of no clock,
   then each due partition in rank order (its clocked inputs, its activation, its clocked outputs), then the outputs of
   no clock. Returns 0, or stops the run. */
static int activate_partitions(tl_plan *plan, int i, int64_t k, double t, int n_due) {
    tl_instance *in = &plan->instances[i];
    tl_clocks *c = in->clocks;
    if (set_parts(plan, i, t, 1, 0, 0) != 0) return 1;
    for (int r = 0; r < c->n_clocks && n_due > 0; r++) {
        int j = c->order[r];
        if (!is_due(c, n_due, j)) continue;
        for (int q = 0; q < c->n_parts; q++)
            if (c->parts[q].kind == j && set_part(plan, i, &c->parts[q], t) != 0) return 1;
        int status = c->activate(in->component, c->clock_vrs[j], t);
        if (status > 1) {
            fail(plan, TL_ERROR_ACTIVATE, i, status, j, -1, t);
            return 1;
        }
        if (c->lock_depth != NULL && *c->lock_depth != 0) { /* one partition at a time: none may return locked */
            fail(plan, TL_ERROR_LOCKS_HELD, i, *c->lock_depth, j, -1, t);
            return 1;
        }
        if (c->activations < c->activation_capacity) {
            c->activation_clock[c->activations] = j;
            c->activation_tick[c->activations++] = k;
        }
        if (read_clock(plan, i, j, t) != 0) return 1;
    }
    return read_clock(plan, i, -1, t);
}

/* A clocked FMU's clocked outputs after its step, as held since their clock's last tick (again each step: what a fault
   or an observer wrote into the outputs since is not the FMU's). */
static void held_outputs(tl_instance *in) {
    for (int q = in->clocks->read_first[1]; q < in->clocks->n_reads; q++) scatter(in, &in->clocks->reads[q]);
}

/* ---- a step ----------------------------------------------------------------------------------------------- */
/* The FMU's inputs set from the gathered groups (the plain FMI 2.0 and FMI 3.0 way). Returns 0, or stops the run. */
static int set_inputs(tl_plan *plan, int i, double t) {
    tl_instance *in = &plan->instances[i];
    for (int g = 0; g < in->n_groups; g++) {
        tl_group *gr = &in->groups[g];
        int status = in->fmi3 ? set3(in, gr->type, gr->dst_vrs, gr->n, gr->values)
                              : in->set[gr->type](in->component, gr->dst_vrs, (size_t)gr->n, gr->values);
        if (status > 1) {
            fail(plan, TL_ERROR_SET, i, status, g, gr->type, t);
            return 1;
        }
    }
    return 0;
}

static int get_outputs(tl_plan *plan, int i, double t) {
    tl_instance *in = &plan->instances[i];
    for (int ty = 0; ty < TL_TYPES; ty++) {
        if (in->n_out[ty] == 0) continue;
        int status = in->fmi3 ? get3(in, ty, in->out_vrs[ty], in->n_out[ty], in->out[ty])
                              : in->get[ty](in->component, in->out_vrs[ty], (size_t)in->n_out[ty], in->out[ty]);
        if (status > 1) {
            fail(plan, TL_ERROR_GET, i, status, -1, ty, t);
            return 1;
        }
    }
    return 0;
}

/* The kernel's own calls of one step: inputs, doStep, outputs (a clocked FMU's: event tells whether in Event Mode
   first, with n_due clocks due). Returns 0, or stops the run. */
static int call_fmu(tl_plan *plan, int i, int64_t k, double t, double h, int event, int n_due) {
    tl_instance *in = &plan->instances[i];
    if (in->clocks != NULL ? clocked_inputs(plan, i, k, t, event, n_due) != 0 : set_inputs(plan, i, t) != 0) return 1;
    int status;
    if (in->fmi3) {
        bool event_needed = false, terminate = false, early_return = false;
        double last_time = t;
        status = in->do_step3(in->component, t, h, true, &event_needed, &terminate, &early_return, &last_time);
        if (status <= 1 && terminate && !plan->ends_allowed) {
            fail(plan, TL_ERROR_TERMINATED_IN_STEP, i, status, -1, -1, t);
            return 1;
        }
        if (status <= 1 && terminate) { /* the run ends at the step's end (or where it returned early), as FMPy's */
            plan->ended_instance = i;
            plan->ended_time = early_return && last_time < t + h ? last_time : t + h;
        }
        if (in->clocks != NULL) in->clocks->event_asked = event_needed;
    } else {
        status = in->do_step(in->component, t, h, 1);
        int terminated = 0;
        double last_time = t + h;
        if (status == TL_DISCARD && plan->ends_allowed && in->boolean_status != NULL && in->boolean_status(in->component, TL_TERMINATED, &terminated) <= 1 &&
            terminated) { /* fmi2Discard, fmi2Terminated: the run ends at the last successful time, as FMPy's */
            if (in->real_status == NULL || in->real_status(in->component, TL_LAST_SUCCESSFUL_TIME, &last_time) > 1) last_time = t;
            plan->ended_instance = i;
            plan->ended_time = last_time;
            status = 0;
        }
    }
    if (status > 1) {
        fail(plan, TL_ERROR_DO_STEP, i, status, -1, -1, t);
        return 1;
    }
    return in->clocks != NULL ? read_clock(plan, i, -1, t) : get_outputs(plan, i, t);
}

/* ---- an isolated FMU over shared memory (tl_link.h) ------------------------------------------------------------ */
/* The host process ended: its end of the reply pipe is closed (or it wrote there, which it does only when it left the
   link). */
static int host_ended(const tl_link *L) {
#if defined(__linux__)
    struct pollfd p = {L->hung_up_fd, POLLIN, 0};
    return poll(&p, 1, 0) > 0;
#else
    (void)L;
    return 1;
#endif
}

/* A signal arrived for Python to handle (its wakeup fd has a byte). */
static int signalled(const tl_link *L) {
#if defined(__linux__)
    if (L->signal_fd < 0) return 0;
    struct pollfd p = {L->signal_fd, POLLIN, 0};
    return poll(&p, 1, 0) > 0;
#else
    (void)L;
    return 0;
#endif
}

/* Wait for the host's answer to request seq: spin (tl_spin_budget: longer where the host usually answers within it),
   then sleep on the futex in slices of at most 2 ms, looking between two at the host's pipe and the watchdog. Returns
   0, or a tl_link_failure (corrupt: the host wrote a sequence number that is neither the last answered nor this one). */
static int await_reply(tl_link *L, uint32_t seq, int *corruption) {
    uint32_t *reply = tl_link_word(L->base, TL_LINK_REPLY);
    int64_t start = tl_monotonic_ns(), now = start;
    int64_t spin = tl_spin_budget(L->spin_ns, L->usual_wait_ns), pause = tl_pause_budget(L->usual_wait_ns);
    for (;;) {
        uint32_t v = __atomic_load_n(reply, __ATOMIC_ACQUIRE);
        if (v == seq) {
            int64_t sent;
            memcpy(&sent, L->base + L->out_offset + offsetof(tl_link_reply, sent_ns), sizeof sent);
            L->usual_wait_ns = tl_spin_learn(L->usual_wait_ns, tl_link_waited(start, sent, tl_monotonic_ns()));
            return 0;
        }
        if (v != seq - 1) {
            *corruption = TL_CORRUPT_SEQUENCE;
            return TL_LINK_CORRUPT;
        }
        now = tl_monotonic_ns();
        if (now - start < spin) {
            tl_spin_wait(start, now, pause);
            continue;
        }
        if (now - start >= L->timeout_ns) return TL_LINK_TIMEOUT;
        if (signalled(L)) return TL_LINK_INTERRUPTED;
        if (host_ended(L) && __atomic_load_n(reply, __ATOMIC_ACQUIRE) != seq) return TL_LINK_ENDED;
        int64_t left = L->timeout_ns - (now - start);
        tl_link_sleep(reply, v, left < 2000000 ? left : 2000000);
    }
}

TL_EXPORT int tl_link_yield(tl_link *L) {
    if (L == NULL) return -1;
    unsigned char *b = L->base;
    uint32_t op = TL_LINK_YIELD;
    memcpy(b + TL_LINK_CALL + 16, &op, sizeof op);
    tl_link_publish(tl_link_word(b, TL_LINK_REQUEST), ++L->seq);
    return 0;
}

/* A failure the host reports of its kernel's sequence (TL_LINK_KERNEL): a kind that sequence has, its group or clock
   and type within the FMU's. */
static int plausible_kernel_failure(const tl_instance *in, const tl_link_reply *r) {
    int type_ok = r->type >= 0 && r->type < TL_TYPES;
    int clock_ok = r->where >= 0 && r->where < in->link->n_clocks;
    int status_ok = r->status >= 0 && r->status <= 4;
    switch (r->kind) {
    case TL_ERROR_SET: return status_ok && r->where >= 0 && r->where < in->n_groups;
    case TL_ERROR_GET: return status_ok && type_ok;
    case TL_ERROR_GET_CLOCKED: return status_ok && type_ok && clock_ok;
    case TL_ERROR_ACTIVATE: return status_ok && clock_ok;
    case TL_ERROR_LOCKS_HELD: return clock_ok;
    case TL_ERROR_DO_STEP: case TL_ERROR_ENTER_EVENT_MODE: case TL_ERROR_SET_CLOCK: case TL_ERROR_UPDATE_DISCRETE_STATES:
    case TL_ERROR_ENTER_STEP_MODE: case TL_ERROR_TERMINATED_IN_EVENT: case TL_ERROR_UNSETTLED: return status_ok;
    default: return 0;
    }
}

/* A step through the link: the gathered inputs into the segment, the request published, the answer awaited and
   checked, the outputs copied out. Whatever the host wrote, only the plan's own offsets are read (all within the
   segment: checked when the link was made), each field checked before use. Returns 0, or stops the run. */
static int step_linked(tl_plan *plan, int i, int64_t k, double t, double h) {
    tl_instance *in = &plan->instances[i];
    tl_link *L = in->link;
    unsigned char *b = L->base;
    for (int g = 0; g < in->n_groups; g++) {
        const tl_group *gr = &in->groups[g];
        memcpy(b + L->in_offset[g], gr->values, (size_t)gr->n * width(gr->type));
    }
    uint32_t op = TL_LINK_STEP;
    memcpy(b + TL_LINK_CALL, &t, sizeof t);
    memcpy(b + TL_LINK_CALL + 8, &h, sizeof h);
    memcpy(b + TL_LINK_CALL + 16, &op, sizeof op);
    memcpy(b + TL_LINK_CALL + 24, &k, sizeof k);
    int64_t sent = tl_monotonic_ns();
    memcpy(b + TL_LINK_SENT, &sent, sizeof sent);
    uint32_t seq = ++L->seq;
    tl_link_publish(tl_link_word(b, TL_LINK_REQUEST), seq);
    int corruption = 0;
    int failure = await_reply(L, seq, &corruption);
    tl_link_reply r;
    memcpy(&r, b + L->out_offset, sizeof r); /* a copy: the host cannot change what is checked after the check */
    int64_t out_bytes = 0;
    for (int ty = 0; ty < TL_TYPES; ty++) out_bytes += (int64_t)in->n_out[ty] * (int64_t)width(ty);
    if (!failure) {
        if ((int64_t)r.out_bytes != out_bytes) corruption = TL_CORRUPT_LENGTH;
        else if (r.call < TL_LINK_OK || r.call > TL_LINK_KERNEL || r.status < 0 || (r.status > 4 && r.call != TL_LINK_KERNEL) ||
                 (r.ended != 0 && r.ended != 1) ||
                 (r.call == TL_LINK_SET && (r.where < 0 || r.where >= in->n_groups)) ||
                 (r.call == TL_LINK_GET && (r.where < 0 || r.where >= TL_TYPES)) ||
                 (r.call == TL_LINK_KERNEL && (r.ended || !plausible_kernel_failure(in, &r))))
            corruption = TL_CORRUPT_CALL;
        else if (r.host_ns < 0 || (r.ended && !(r.last_time >= t && r.last_time <= t + h)))
            corruption = TL_CORRUPT_TIME;
        if (corruption) failure = TL_LINK_CORRUPT;
    }
    if (failure) {
        fail(plan, TL_ERROR_LINK, i, failure, corruption, -1, t);
        return 1;
    }
    in->host_ns += r.host_ns;
    if (r.call == TL_LINK_SET) {
        fail(plan, TL_ERROR_SET, i, r.status, r.where, in->groups[r.where].type, t);
        return 1;
    }
    if (r.call == TL_LINK_GET) {
        fail(plan, TL_ERROR_GET, i, r.status, -1, r.where, t);
        return 1;
    }
    if (r.call == TL_LINK_KERNEL) {
        int type = r.kind == TL_ERROR_SET ? in->groups[r.where].type : r.type;
        fail(plan, (enum tl_error_kind)r.kind, i, r.status, r.where, type, t);
        return 1;
    }
    if (r.call == TL_LINK_DO_STEP) {
        if (!(r.ended && plan->ends_allowed)) { /* an end asked for that the system treats as a failure: worded as in
                                                   process by the FMU's version (failures.py) */
            fail(plan, r.ended ? TL_ERROR_TERMINATED_IN_STEP : TL_ERROR_DO_STEP, i, r.status, -1, -1, t);
            return 1;
        }
        plan->ended_instance = i; /* fmi2Discard, fmi2Terminated: the run ends at the last successful time, as in process */
        plan->ended_time = r.last_time;
    }
    int64_t at = L->out_offset + TL_LINK_HEADER;
    for (int ty = 0; ty < TL_TYPES; ty++) {
        size_t bytes = (size_t)in->n_out[ty] * width(ty);
        memcpy(in->out[ty], b + at, bytes);
        at += (int64_t)bytes;
    }
    return 0;
}

/* One instance's step at tick k (time t): inputs, doStep, outputs. Returns 0, or stops the run. */
static int step_instance(tl_plan *plan, int i, int64_t k, double t) {
    tl_instance *in = &plan->instances[i];
    double h = in->every * plan->tick;
    int cut = !plan->closing && plan->stop_time > 0 && t + h > plan->stop_time + 1e-9 * plan->tick;
    if (cut) h = plan->stop_time - t; /* the shorter last communication step: it ends at the stop time */
    for (int g = 0; g < in->n_groups; g++) gather(&in->groups[g], group_source(plan, &in->groups[g], k));
    if (plan->n_faults) apply_faults(plan, i, TL_INPUTS, t);
    if (in->hook_inputs && plan->hook_callback(i, TL_INPUTS, t) != 0) {
        fail(plan, TL_ERROR_HOOK_CALLBACK, i, 0, -1, -1, t);
        return 1;
    }
    /* the profile times the FMU's calls (or the callback that makes them elsewhere); a clocked FMU's staging and held
       outputs are the master's work */
    int event = 0, n_due = 0;
    if (!in->by_callback && in->clocks != NULL) event = clocked_event(in, k, t, h, &n_due);
    int64_t started = plan->profile ? profile_ns(plan->profile) : 0;
    int failed = 0;
    if (in->by_callback) {
        int done = plan->step_callback(i, t, h);
        if (done == 2) {
            plan->ended_instance = i;
        } else if (done != 0) {
            fail(plan, TL_ERROR_STEP_CALLBACK, i, 0, -1, -1, t);
            failed = 1;
        }
    } else if (in->link != NULL) {
        failed = step_linked(plan, i, k, t, h);
    } else {
        failed = in->clocks != NULL && in->clocks->activate != NULL ? activate_partitions(plan, i, k, t, n_due)
                                                                    : call_fmu(plan, i, k, t, h, event, n_due);
    }
    if (plan->profile) {
        int64_t took = profile_ns(plan->profile) - started;
        in->seconds += (double)took * 1e-9;
        profile_add(in->histogram, &in->fastest_ns, &in->slowest_ns, took);
    }
    if (failed) return 1;
    if (!in->by_callback && in->clocks != NULL) held_outputs(in);
    if (plan->n_faults) apply_faults(plan, i, TL_OUTPUTS, t);
    if (in->hook_outputs && plan->hook_callback(i, TL_OUTPUTS, t) != 0) {
        fail(plan, TL_ERROR_HOOK_CALLBACK, i, 0, -1, -1, t);
        return 1;
    }
    /* the time the outputs belong to: the step's end (FMI's rule), or its start for an instance that computes them there */
    double when = in->continuous ? (cut ? plan->stop_time : t + h) : t;
    int ended = plan->ended_instance == i;
    if (ended && in->continuous) when = plan->ended_time;
    /* a step that ended the run without advancing (fmi2Discard: its last successful time is its start) has no sample:
       the last valid one is logged already */
    if (plan->record_capacity > 0 && !(ended && plan->ended_time <= t + 1e-9 * h)) record(plan, i, k, when);
    return ended; /* an end asked for stops the tick here, without an error */
}

/* For an isolated FMU's host: the kernel's own sequence of one step of instance 0 (a clocked FMU's Event Mode, a
   Scheduled Execution FMU's partitions), its groups' values already in place (no gathering, fault, hook or record:
   the master's). A failure, or an end the FMU asked for, goes into the reply as tl_host.c's own step reports them;
   the plan allows ends (the master decides). Returns whether the step failed. */
TL_EXPORT int tl_step_alone(void *alone, int64_t k, double t, double h, tl_link_reply *reply) {
    tl_plan *plan = alone;
    tl_instance *in = &plan->instances[0];
    plan->error_kind = TL_ERROR_NONE;
    plan->ended_instance = -1;
    int event = 0, n_due = 0;
    if (in->clocks != NULL) event = clocked_event(in, k, t, h, &n_due);
    int failed = in->clocks != NULL && in->clocks->activate != NULL ? activate_partitions(plan, 0, k, t, n_due)
                                                                    : call_fmu(plan, 0, k, t, h, event, n_due);
    if (failed) {
        reply->call = TL_LINK_KERNEL;
        reply->kind = (int32_t)plan->error_kind;
        reply->status = plan->error_status;
        reply->where = plan->error_group;
        reply->type = plan->error_type;
        return 1;
    }
    if (in->clocks != NULL) held_outputs(in);
    if (plan->ended_instance == 0) {
        reply->call = TL_LINK_DO_STEP;
        reply->ended = 1;
        reply->status = 2; /* fmi2Discard: an end asked for, as tl_host.c's own step reports it */
        reply->last_time = plan->ended_time;
    }
    return 0;
}

static void forget_records(tl_plan *plan) {
    plan->error_kind = TL_ERROR_NONE;
    plan->ended_instance = -1;
    plan->records = 0;
    plan->events = 0;
    for (int i = 0; i < plan->n_instances; i++) {
        plan->rows[i] = 0;
        if (plan->instances[i].clocks != NULL) plan->instances[i].clocks->activations = 0;
    }
}

TL_EXPORT int tl_close(tl_plan *plan, double t) {
    forget_records(plan);
    plan->closing = 1;
    int failed = 0;
    for (int i = 0; i < plan->n_instances && !failed; i++)
        if (!plan->instances[i].continuous) failed = step_instance(plan, i, plan->ticks_done, t);
    plan->closing = 0;
    return failed;
}

TL_EXPORT int64_t tl_run(tl_plan *plan, int64_t n) {
    forget_records(plan);
    int64_t done = 0;
    for (; done < n; done++) {
        int64_t k = plan->ticks_done;
        double t = plan->start_time + (double)k * plan->tick; /* start_time 0: 0.0 + k * tick == k * tick exactly */
        if (plan->realtime_factor > 0) {
            int64_t deadline = plan->realtime_start_ns +
                (int64_t)((double)(k - plan->realtime_first_tick) * plan->tick / plan->realtime_factor * 1e9);
            int64_t now = tl_monotonic_ns();
            int late = now >= deadline;
            if (!late) {
                sleep_until(deadline);
                now = tl_monotonic_ns();
            }
            if (plan->lateness != NULL) plan->lateness[done] = (double)(now - deadline) * 1e-9;
            if (plan->overrun != NULL) plan->overrun[done] = (int8_t)late;
        }
        int64_t started = plan->profile ? profile_ns(plan->profile) : 0; /* off: this branch is the profile's cost */
        for (int i = 0; i < plan->n_instances; i++) {
            if (k % plan->instances[i].every) continue;
            if (step_instance(plan, i, k, t) != 0) return done;
        }
        tl_store_history(plan, k + 1);
        plan->ticks_done = k + 1;
        if (plan->profile) {
            int64_t took = profile_ns(plan->profile) - started;
            plan->tick_ns += took;
            profile_add(plan->tick_histogram, &plan->fastest_tick_ns, &plan->slowest_tick_ns, took);
        }
    }
    return done;
}
