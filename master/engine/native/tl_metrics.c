/* The loop's metrics over one call's records (engine/metrics.py, Metrics; the campaign's extras: campaign/metrics.py).
 *
 * The records are walked in the order the steps happened: a step of the plant or of the reference replaces what is
 * carried of its outputs, a step of the actuators (the controller) is sampled with what is carried then, the values
 * "just before" it. Every sum runs in that order, one addition a step, so the results do not depend on how the
 * steps were batched, and each operation is the one numpy's vectorized form did (-ffp-contract=off): the same bits.
 *
 * sizes: n_tracked, n_inputs, n_state, has_bounds, extras.
 * cols: plant columns [n_tracked], reference columns [n_tracked], input columns [n_inputs], then with extras the
 *       state columns [n_state] and, with bounds, the actuators' lower and upper bound columns [n_state each].
 * limits: tick, settle, lo, hi, tau, eps.
 * sums: ISE [n_tracked], IADU [n_inputs]; carry: x [n_tracked], ref [n_tracked], previous u [n_inputs], state [n_state].
 * counts: has_previous_u, steps, saturated, contained; worst: the largest tracking error after settle (in and out). */
#include <math.h>
#include <stdint.h>

#define TL_MAX_COLUMNS 64

#if defined(_WIN32)
#define TL_EXPORT __declspec(dllexport)
#else
#define TL_EXPORT __attribute__((visibility("default")))
#endif

TL_EXPORT int64_t tl_metrics_batch(int64_t n, const int32_t *instance, const int64_t *row, const double *time,
                                   const int64_t *who, const int64_t *sizes, const int64_t *cols,
                                   const double *plant_rows, int64_t plant_width, const double *ref_rows,
                                   int64_t ref_width, const double *act_rows, int64_t act_width, const double *limits,
                                   double *sums, double *carry, int64_t *counts, double *worst)
{
    const int64_t n_tracked = sizes[0], n_inputs = sizes[1], n_state = sizes[2], bounds = sizes[3], extras = sizes[4];
    if (n_tracked < 0 || n_tracked > TL_MAX_COLUMNS || n_inputs < 0 || n_state < 0 || (extras && (n_tracked < 3 || n_inputs < 2)))
        return -1;
    const int64_t *plant_cols = cols, *ref_cols = cols + n_tracked, *input_cols = ref_cols + n_tracked;
    const int64_t *state_cols = input_cols + n_inputs, *lo_cols = state_cols + n_state, *hi_cols = lo_cols + n_state;
    const double tick = limits[0], settle = limits[1], lo = limits[2] + limits[5], hi = limits[3] - limits[5];
    const double tau = limits[4] - limits[5];
    double *ise = sums, *iadu = sums + n_tracked;
    double *x = carry, *ref = carry + n_tracked, *previous = ref + n_tracked, *state = previous + n_inputs;
    double batch_worst = 0.0;
    int any_late = 0, nan_late = 0;
    for (int64_t p = 0; p < n; p++) {
        const int32_t i = instance[p];
        if (i == who[0]) {
            const double *r = plant_rows + row[p] * plant_width;
            for (int64_t j = 0; j < n_tracked; j++)
                x[j] = r[plant_cols[j]];
            if (extras)
                for (int64_t j = 0; j < n_state; j++)
                    state[j] = r[state_cols[j]];
        }
        if (i == who[1]) {
            const double *r = ref_rows + row[p] * ref_width;
            for (int64_t j = 0; j < n_tracked; j++)
                ref[j] = r[ref_cols[j]];
        }
        if (i != who[2])
            continue;
        const double *r = act_rows + row[p] * act_width;
        double e[TL_MAX_COLUMNS];
        for (int64_t j = 0; j < n_tracked; j++) {
            e[j] = x[j] - ref[j];
            const double square = e[j] * e[j];
            ise[j] = ise[j] + square * tick;
        }
        for (int64_t j = 0; j < n_inputs; j++) {
            const double u = r[input_cols[j]];
            if (counts[0])
                iadu[j] = iadu[j] + fabs(u - previous[j]);
            previous[j] = u;
        }
        counts[0] = 1;
        counts[1] += 1;
        if (!extras)
            continue;
        if (time[p] >= settle) {  /* numpy's max of the batch: NaN if any is NaN */
            double s = e[0] * e[0];
            s = s + e[1] * e[1];
            s = s + e[2] * e[2];
            const double err = sqrt(s);
            if (isnan(err))
                nan_late = 1;
            else if (!any_late || err > batch_worst)
                batch_worst = err;
            any_late = 1;
        }
        int saturated = 0;
        for (int64_t j = 0; j < 2; j++) {
            const double f = previous[j];
            saturated |= (f <= lo) | (f >= hi);
        }
        for (int64_t j = 2; j < n_inputs; j++)
            saturated |= fabs(previous[j]) >= tau;
        counts[2] += saturated;
        if (bounds) {
            int inside = 1;
            for (int64_t j = 0; j < n_state; j++)
                inside &= (r[lo_cols[j]] <= state[j]) & (state[j] <= r[hi_cols[j]]);
            counts[3] += inside;
        }
    }
    if (any_late) {  /* Python's max(worst, batch's): the batch's only when larger (a NaN never is) */
        const double batch = nan_late ? NAN : batch_worst;
        if (batch > *worst)
            *worst = batch;
    }
    return 0;
}
