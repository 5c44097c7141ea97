/* The 3D scene's messages (scene.py) for many steps of the plant in one call: the same numbers by the same
   arithmetic (libm's sin and cos, products in the order scene.py writes them) printed into the same JSON template
   with the same formats (%d, %.17g), so a message is byte for byte the Python encoder's. */
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#if defined(__GNUC__)
#define TL_EXPORT __attribute__((visibility("default")))
#else
#define TL_EXPORT
#endif

#define KEYS 9      /* x, y, z, x_B, y_B, z_B, phi_B, theta_B, psi_B */
#define NUMBERS 20  /* stamp (2), body (3), quaternion (4), up to two thrusters (6), load (3); slack for one more */

typedef struct { double x, y, z, w; } quaternion;

#if defined(__SIZEOF_INT128__)
/* x as printf("%.17g") prints it, for 1e-15 <= |x| < 1e17 (the scene's numbers), exactly and about ten times faster
   than glibc's printf: x = m 2^e, so x 10^p = m 5^p 2^(e + p) is an integer of at most 128 bits, rounded half to
   even to 17 digits. Returns the characters written (at most 24), or 0 for x outside that range (printf's then). */
static int print_g17(double x, char *out) {
    double a = fabs(x);
    if (!(a >= 1e-15 && a < 1e17)) return 0;
    int e2;
    uint64_t m = (uint64_t)ldexp(frexp(a, &e2), 53); /* a = m 2^(e2 - 53), m < 2^53 exactly */
    e2 -= 53;
    int e10 = (int)floor(log10(a));
    uint64_t digits = 0;
    for (int attempt = 0; attempt < 3; attempt++) {
        int p = 16 - e10; /* 0 <= p <= 31: m 5^p < 2^(53 + 72) */
        if (p < 0 || p > 31) return 0;
        unsigned __int128 n = m, rest = 0, half = 0;
        for (int k = 0; k < p; k++) n *= 5;
        int shift = e2 + p;
        if (shift >= 0) {
            if (shift > 60) return 0;
            n <<= shift;
        } else {
            if (-shift >= 127) return 0;
            rest = n & (((unsigned __int128)1 << -shift) - 1);
            half = (unsigned __int128)1 << (-shift - 1);
            n >>= -shift; /* the exact value's whole part: it decides the exponent, before rounding */
        }
        if (n >= (unsigned __int128)100000000000000000ULL) { /* 18 digits: the exponent was one too small */
            e10++;
            continue;
        }
        if (n < (unsigned __int128)10000000000000000ULL) { /* 16 digits: one too large */
            e10--;
            continue;
        }
        if (rest > half || (rest == half && half && (n & 1))) n++;
        if (n == (unsigned __int128)100000000000000000ULL) { /* rounded up to a power of ten */
            n = 10000000000000000ULL;
            e10++;
        }
        digits = (uint64_t)n;
        break;
    }
    if (!digits) return 0;
    char d[17];
    for (int k = 16; k >= 0; k--, digits /= 10) d[k] = (char)('0' + digits % 10);
    int last = 16; /* %g drops the fraction's trailing zeros */
    char *o = out;
    if (x < 0) *o++ = '-';
    if (e10 < -4 || e10 >= 17) {
        while (last > 0 && d[last] == '0') last--;
        *o++ = d[0];
        if (last > 0) {
            *o++ = '.';
            memcpy(o, d + 1, (size_t)last);
            o += last;
        }
        int ex = e10 < 0 ? -e10 : e10;
        *o++ = 'e';
        *o++ = e10 < 0 ? '-' : '+';
        if (ex >= 100) *o++ = (char)('0' + ex / 100);
        *o++ = (char)('0' + ex / 10 % 10);
        *o++ = (char)('0' + ex % 10);
    } else if (e10 >= 0) {
        int whole = e10 + 1;
        while (last >= whole && d[last] == '0') last--;
        memcpy(o, d, (size_t)whole);
        o += whole;
        if (last >= whole) {
            *o++ = '.';
            memcpy(o, d + whole, (size_t)(last - whole + 1));
            o += last - whole + 1;
        }
    } else {
        while (d[last] == '0') last--;
        *o++ = '0';
        *o++ = '.';
        for (int k = 0; k < -e10 - 1; k++) *o++ = '0';
        memcpy(o, d, (size_t)(last + 1));
        o += last + 1;
    }
    *o = 0;
    return (int)(o - out);
}
#else
static int print_g17(double x, char *out) { (void)x, (void)out; return 0; }
#endif

/* x as printf("%.17g") prints it (the Python encoder's '%.17g' % x); exposed for the tests. */
TL_EXPORT int tl_scene_g17(double x, char *out) {
    int wrote = print_g17(x, out);
    return wrote ? wrote : snprintf(out, 32, "%.17g", x);
}

static quaternion zyx(double phi, double theta, double psi) {
    double cr = cos(phi / 2), sr = sin(phi / 2);
    double cp = cos(theta / 2), sp = sin(theta / 2);
    double cy = cos(psi / 2), sy = sin(psi / 2);
    quaternion q = {sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
                    cr * cp * cy + sr * sp * sy};
    return q;
}

static void rotate(quaternion q, const double *v, double *out) {
    double tx = 2 * (q.y * v[2] - q.z * v[1]), ty = 2 * (q.z * v[0] - q.x * v[2]), tz = 2 * (q.x * v[1] - q.y * v[0]);
    out[0] = v[0] + q.w * tx + q.y * tz - q.z * ty;
    out[1] = v[1] + q.w * ty + q.z * tx - q.x * tz;
    out[2] = v[2] + q.w * tz + q.x * ty - q.y * tx;
}

/* n messages, one per row of values (row i at values + i * stride; its pose at index[0..9)), at log times ns[i], into
   out (capacity bytes): message i is out[ends[i - 1]:ends[i]], empty for a non-finite pose (nothing to draw).
   The template: n_slots + 1 literal pieces (piece k is text[piece_ends[k - 1]:piece_ends[k]]) around n_slots numbers,
   slot k printing number order[k] (0, 1: the stamp's seconds and nanoseconds, %d; the rest %.17g). Numbers:
   stamp, body, quaternion, each thruster centre (thrusters: n_thrusters offsets in the body frame), then the load
   when with_load. Returns 0, or -1 when out is too small (nothing after ends[i - 1] is valid then). */
TL_EXPORT int tl_scene_encode(int64_t n, const double *values, int64_t stride, const int32_t *index, const uint64_t *ns,
                              int n_thrusters, const double *thrusters, int with_load, const char *text,
                              const int64_t *piece_ends, int n_slots, const int32_t *order, char *out, int64_t capacity,
                              int64_t *ends) {
    int64_t used = 0;
    if (n_thrusters > 2) return -1;
    for (int64_t i = 0; i < n; i++) {
        const double *row = values + i * stride;
        double p[KEYS], number[NUMBERS];
        int finite = 1;
        for (int k = 0; k < KEYS; k++) {
            p[k] = row[index[k]];
            finite &= isfinite(p[k]) != 0;
        }
        if (!finite) {
            ends[i] = used;
            continue;
        }
        quaternion q = zyx(p[6], p[7], p[8]);
        int m = 2;
        number[m++] = p[3], number[m++] = p[4], number[m++] = p[5];
        number[m++] = q.x, number[m++] = q.y, number[m++] = q.z, number[m++] = q.w;
        for (int t = 0; t < n_thrusters; t++) {
            double off[3];
            rotate(q, thrusters + 3 * t, off);
            number[m++] = p[3] + off[0], number[m++] = p[4] + off[1], number[m++] = p[5] + off[2];
        }
        if (with_load) number[m++] = p[0], number[m++] = p[1], number[m++] = p[2];
        uint64_t sec = ns[i] / 1000000000u, nsec = ns[i] % 1000000000u;
        int64_t from = 0;
        for (int k = 0; k <= n_slots; k++) {
            int64_t piece = piece_ends[k] - from;
            if (used + piece + 32 > capacity) return -1;
            memcpy(out + used, text + from, (size_t)piece);
            used += piece;
            from = piece_ends[k];
            if (k == n_slots) break;
            int s = order[k];
            int wrote = s == 0 ? snprintf(out + used, 32, "%" PRIu64, sec)
                        : s == 1 ? snprintf(out + used, 32, "%" PRIu64, nsec)
                                 : tl_scene_g17(number[s], out + used);
            used += wrote;
        }
        ends[i] = used;
    }
    return 0;
}
