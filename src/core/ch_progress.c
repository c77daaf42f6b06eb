#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include "ch_progress.h"

#include <time.h>

#include <stdarg.h>
#include <stdio.h>

void ch_progress_report(const ch_progress *p, const char *stage, double fraction) {
  if (p && p->fn) p->fn(p->user, stage ? stage : "", fraction);
}

void ch_progress_reportf(const ch_progress *p, double fraction, const char *fmt, ...) {
  if (!p || !p->fn) return;
  char text[256];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof text, fmt, ap);
  va_end(ap);
  p->fn(p->user, text, fraction);
}

double ch_progress_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
