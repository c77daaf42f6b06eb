#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

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
