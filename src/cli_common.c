#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ch_curves.h"
#include "ch_exr.h"
#include "cli.h"

static void print_warning(void *user, const char *message) {
  (void)user;
  fprintf(stderr, "chisel: warning: %s\n", message);
}

ch_error cli_error(void) {
  ch_error err = {0};
  err.warn = print_warning;
  return err;
}

int cli_fail(const ch_error *err) {
  fprintf(stderr, "chisel: %s\n", err->message[0] ? err->message : ch_status_name(err->status));
  int code = ch_status_exit_code(err->status);
  return code ? code : 1;
}

int cli_usage_error(const char *cmd, const char *fmt, ...) {
  fprintf(stderr, "chisel %s: ", cmd);
  va_list ap;
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fprintf(stderr, " (see chisel %s --help)\n", cmd);
  return 2;
}

int cli_parse_int(const char *cmd, const char *option, const char *text, long lo, long hi,
                  long *out) {
  char *end;
  errno = 0;
  long v = strtol(text, &end, 10);
  if (end == text || *end || errno) {
    cli_usage_error(cmd, "%s expects an integer, got '%s'", option, text);
    return -1;
  }
  if (v < lo || v > hi) {
    cli_usage_error(cmd, "%s %ld is outside %ld..%ld", option, v, lo, hi);
    return -1;
  }
  *out = v;
  return 0;
}

int cli_parse_doubles(const char *cmd, const char *option, const char *text, int n, double *out) {
  const char *p = text;
  for (int i = 0; i < n; i++) {
    char *end;
    errno = 0;
    out[i] = strtod(p, &end);
    if (end == p || errno || !isfinite(out[i]) || (i + 1 < n ? *end != ',' : *end != '\0')) {
      cli_usage_error(cmd, "%s expects %d comma-separated numbers, got '%s'", option, n, text);
      return -1;
    }
    p = end + 1;
  }
  return 0;
}

const char *cli_option_value(const char *cmd, int argc, char **argv, int *i) {
  if (*i + 1 >= argc) {
    cli_usage_error(cmd, "option %s needs a value", argv[*i]);
    return NULL;
  }
  *i += 1;
  return argv[*i];
}

int cli_is_help(const char *arg) { return !strcmp(arg, "-h") || !strcmp(arg, "--help"); }

int cli_check_output(const char *cmd, const char *option, const char *path) {
  if (!path[0]) return cli_usage_error(cmd, "%s: empty output path", option);
  const char *slash = strrchr(path, '/');
  char dir[PATH_MAX];
  if (!slash) {
    strcpy(dir, ".");
  } else if (slash == path) {
    strcpy(dir, "/");
  } else {
    size_t n = (size_t)(slash - path);
    if (n >= sizeof dir) return cli_usage_error(cmd, "%s: output path too long", option);
    memcpy(dir, path, n);
    dir[n] = '\0';
  }
  if (access(dir, W_OK) != 0) {
    fprintf(stderr, "chisel: %s: cannot write into directory '%s': %s\n", path, dir, strerror(errno));
    return 2;
  }
  return 0;
}

void cli_outputs_add(cli_outputs *outs, const char *path) {
  if (outs->count < (int)(sizeof outs->paths / sizeof outs->paths[0])) outs->paths[outs->count++] = path;
}

void cli_outputs_remove_all(cli_outputs *outs) {
  for (int i = 0; i < outs->count; i++) remove(outs->paths[i]);
  outs->count = 0;
}

int cli_quiet = 0;
int cli_argc = 0;
char **cli_argv = NULL;

void cli_result(const char *fmt, ...) {
  if (cli_quiet) return;
  fputs("chisel: ", stderr);
  va_list ap;
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputc('\n', stderr);
}

int cli_is_stdout(const char *path) { return path && !strcmp(path, "-"); }

int cli_refuse_stdout(const char *cmd, const char *option, const char *format) {
  return cli_usage_error(cmd, "%s -: %s cannot be written to standard output (it is written with seeks); give a file name",
                         option, format);
}

/* Optimal string alignment distance: insertions, deletions, substitutions
 * and swaps of neighbours cost one each (the slips typing makes). */
static int edit_distance(const char *a, const char *b) {
  enum { MAX = 64 };
  size_t n = strlen(a), m = strlen(b);
  if (n >= MAX || m >= MAX) return MAX;
  int d[MAX + 1][MAX + 1];
  for (size_t i = 0; i <= n; i++) d[i][0] = (int)i;
  for (size_t j = 0; j <= m; j++) d[0][j] = (int)j;
  for (size_t i = 1; i <= n; i++)
    for (size_t j = 1; j <= m; j++) {
      int cost = a[i - 1] != b[j - 1];
      int best = d[i - 1][j] + 1;
      if (d[i][j - 1] + 1 < best) best = d[i][j - 1] + 1;
      if (d[i - 1][j - 1] + cost < best) best = d[i - 1][j - 1] + cost;
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] && d[i - 2][j - 2] + 1 < best)
        best = d[i - 2][j - 2] + 1;
      d[i][j] = best;
    }
  return d[n][m];
}

const char *cli_suggest(const char *word, const char *const *candidates, int n) {
  const char *best = NULL;
  int best_d = 0;
  for (int i = 0; i < n; i++) {
    int d = edit_distance(word, candidates[i]);
    if (!best || d < best_d) best = candidates[i], best_d = d;
  }
  /* Two slips, or a third of a long word: closer than that is a guess. */
  size_t len = strlen(word);
  int allowed = len >= 9 ? (int)(len / 3) : 2;
  if (len <= 3) allowed = 1;
  return best && best_d <= allowed ? best : NULL;
}

int cli_parse_fill_height(const char *cmd, const char *text, ch_svg_desc *desc) {
  double h;
  if (cli_parse_doubles(cmd, "--fill-height", text, 1, &h)) return -1;
  if (h == 0.0 || fabs(h) > 1e6) {
    cli_usage_error(cmd, "--fill-height %s: expected a nonzero height (object units; negative carves)", text);
    return -1;
  }
  desc->fill_height = h;
  return 0;
}

double cli_height_luminance(const float *plane, size_t n, const char *name, ch_exr_write_desc *desc,
                            char *scale_text, size_t scale_size) {
  double s = 0.0;
  for (size_t i = 0; i < n; i++)
    if (isfinite(plane[i])) s = fmax(s, fabs((double)plane[i]));
  desc->luminance = name;
  desc->luminance_offset = 0.5;
  desc->luminance_scale = s > 0.0 ? 0.5 / s : 0.5;
  snprintf(scale_text, scale_size, "%.9g", s);
  return s;
}
