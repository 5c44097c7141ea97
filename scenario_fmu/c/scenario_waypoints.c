/* Quintic Hermite segments (scenario_waypoints.h). On s = (t - t_i) / T in [0, 1], with d the scaled end data
   [p0, T v0, T^2 a0, p1, T v1, T^2 a1], the monomial coefficients are those of waypoints.B_HERMITE. */
#if !defined(_WIN32)
#define _POSIX_C_SOURCE 200809L /* stat: a knot file is a regular file (a FIFO would block the reader forever) */
#endif
#include "tl_platform.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#if !defined(_WIN32)
#include <sys/stat.h>
#endif

#include "scenario_waypoints.h"

void tl_waypoints_axis(int n, const double* t, const double* p, const double* v, const double* a, double at, double out[3]) {
  int lo = 0, hi = n - 1;
  double T, s, dp, m0, m1, a0, a1, c[6];
  if (at < t[0] || at >= t[n - 1]) {
    out[0] = at < t[0] ? p[0] : p[n - 1];
    out[1] = out[2] = 0.0;
    return;
  }
  while (hi - lo > 1) { /* t[lo] <= at < t[hi] */
    int mid = (lo + hi) / 2;
    if (t[mid] <= at) lo = mid;
    else hi = mid;
  }
  T = t[hi] - t[lo];
  s = (at - t[lo]) / T;
  dp = p[hi] - p[lo];
  m0 = T * v[lo], m1 = T * v[hi], a0 = T * T * a[lo], a1 = T * T * a[hi];
  c[0] = p[lo];
  c[1] = m0;
  c[2] = 0.5 * a0;
  c[3] = 10.0 * dp - 6.0 * m0 - 4.0 * m1 - 1.5 * a0 + 0.5 * a1;
  c[4] = -15.0 * dp + 8.0 * m0 + 7.0 * m1 + 1.5 * a0 - a1;
  c[5] = 6.0 * dp - 3.0 * m0 - 3.0 * m1 - 0.5 * a0 + 0.5 * a1;
  out[0] = c[0] + s * (c[1] + s * (c[2] + s * (c[3] + s * (c[4] + s * c[5]))));
  out[1] = (c[1] + s * (2.0 * c[2] + s * (3.0 * c[3] + s * (4.0 * c[4] + s * 5.0 * c[5])))) / T;
  out[2] = (2.0 * c[2] + s * (6.0 * c[3] + s * (12.0 * c[4] + s * 20.0 * c[5]))) / (T * T);
}

/* One line into buf (without its end): 1, 0 at the end of the file, -1 when longer than the buffer holds. */
static int read_line(FILE* f, char* buf, size_t size) {
  size_t len;
  if (fgets(buf, (int)size, f) == NULL) return 0;
  len = strlen(buf);
  if (len + 1 == size && buf[len - 1] != '\n' && !feof(f)) return -1;
  while (len > 0 && (buf[len - 1] == '\n' || buf[len - 1] == '\r')) buf[--len] = '\0';
  return 1;
}

#define FAIL(...)                        \
  do {                                   \
    snprintf(why, why_size, __VA_ARGS__); \
    if (f != NULL) fclose(f);            \
    return 1;                            \
  } while (0)

int tl_waypoints_load(const char* path, double knot[TL_KNOT_COLUMNS][TL_MAX_WAYPOINTS], int* n, char* why, size_t why_size) {
  char line[TL_KNOT_LINE];
  FILE* f = NULL;
  int number = 1, got, column;
#if !defined(_WIN32)
  struct stat info;
  if (stat(path, &info) != 0) FAIL("%s: %s", path, strerror(errno));
  if (!S_ISREG(info.st_mode)) FAIL("%s: not a regular file", path);
#endif
  f = fopen(path, "r");
  if (f == NULL) FAIL("%s: %s", path, strerror(errno));
  got = read_line(f, line, sizeof line);
  if (got <= 0 || strcmp(line, TL_KNOT_HEADER) != 0) FAIL("%s: line 1 must be the header %s", path, TL_KNOT_HEADER);
  *n = 0;
  while ((got = read_line(f, line, sizeof line)) != 0) {
    const char* p = line;
    ++number;
    if (got < 0) FAIL("%s: line %d is longer than %d characters", path, number, TL_KNOT_LINE - 2);
    if (*n == TL_MAX_WAYPOINTS) FAIL("%s: more than %d knots", path, TL_MAX_WAYPOINTS);
    for (column = 0; column < TL_KNOT_COLUMNS; ++column) {
      char* end;
      knot[column][*n] = strtod(p, &end);
      if (end == p) FAIL("%s: line %d: column %d is not a number", path, number, column + 1);
      p = end;
      while (*p == ' ') ++p;
      if (column + 1 < TL_KNOT_COLUMNS && *p++ != ',') FAIL("%s: line %d: %d numbers, not %d", path, number, column + 1, TL_KNOT_COLUMNS);
    }
    if (*p != '\0') FAIL("%s: line %d: more than %d numbers", path, number, TL_KNOT_COLUMNS);
    ++*n;
  }
  if (ferror(f)) FAIL("%s: a read failed", path);
  fclose(f);
  return 0;
}
