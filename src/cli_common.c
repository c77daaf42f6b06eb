#define _DEFAULT_SOURCE /* (TIOCGWINSZ) */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "ch_curves.h"
#include "ch_exr.h"
#include "ch_file.h"
#include "cli.h"

/* ---- progress on a terminal ---- */
static struct {
  pthread_mutex_t lock;
  pthread_cond_t wake;
  pthread_t thread;
  int running, stop, shown;
  double start, fraction;
  char cmd[32], stage[256];
} progress = {.lock = PTHREAD_MUTEX_INITIALIZER, .wake = PTHREAD_COND_INITIALIZER};

static double seconds_now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* (under progress.lock) */
static void progress_clear_locked(void) {
  if (progress.shown) fputs("\r\033[K", stderr);
  progress.shown = 0;
}

static void progress_draw_locked(void) {
  char head[64], tail[64], stage[256];
  snprintf(head, sizeof head, "chisel %s: ", progress.cmd);
  if (progress.fraction >= 0.0) {
    /* a bar of the stage's fraction: where a long stage stands at a glance */
    char bar[21];
    int filled = (int)(20.0 * fmin(1.0, progress.fraction));
    for (int i = 0; i < 20; i++) bar[i] = i < filled ? '#' : '.';
    bar[20] = '\0';
    snprintf(tail, sizeof tail, " [%s] %.0f%% (%.0f s)", bar, 100.0 * fmin(1.0, progress.fraction),
             seconds_now() - progress.start);
  }
  else
    snprintf(tail, sizeof tail, " (%.0f s)", seconds_now() - progress.start);
  snprintf(stage, sizeof stage, "%s", progress.stage[0] ? progress.stage : "working");
  /* one line, never wrapped: the stage gives way, the time stays */
  struct winsize ws;
  size_t width = ioctl(2, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 1 ? ws.ws_col - 1u : 79u;
  size_t room = width > strlen(head) + strlen(tail) + 8 ? width - strlen(head) - strlen(tail) : 8;
  if (strlen(stage) > room) strcpy(stage + room - 3, "...");
  fprintf(stderr, "\r%s%s%s\033[K", head, stage, tail);
  fflush(stderr);
  progress.shown = 1;
}

static void progress_clear(void) {
  pthread_mutex_lock(&progress.lock);
  progress_clear_locked();
  pthread_mutex_unlock(&progress.lock);
}

static void *progress_ticker(void *arg) {
  (void)arg;
  pthread_mutex_lock(&progress.lock);
  while (!progress.stop) {
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until);
    until.tv_nsec += 250000000L;
    if (until.tv_nsec >= 1000000000L) until.tv_sec++, until.tv_nsec -= 1000000000L;
    pthread_cond_timedwait(&progress.wake, &progress.lock, &until);
    if (!progress.stop && seconds_now() - progress.start >= 2.0) progress_draw_locked();
  }
  progress_clear_locked();
  pthread_mutex_unlock(&progress.lock);
  return NULL;
}

static void on_progress(void *user, const char *stage, double fraction) {
  (void)user;
  pthread_mutex_lock(&progress.lock);
  snprintf(progress.stage, sizeof progress.stage, "%s", stage);
  progress.fraction = fraction;
  pthread_mutex_unlock(&progress.lock);
}

const ch_progress *cli_progress_start(const char *cmd) {
  static const ch_progress reporter = {on_progress, NULL};
  if (progress.running || !isatty(2)) return NULL;
  snprintf(progress.cmd, sizeof progress.cmd, "%s", cmd);
  progress.stage[0] = '\0';
  progress.fraction = -1.0;
  progress.start = seconds_now();
  progress.stop = 0;
  if (pthread_create(&progress.thread, NULL, progress_ticker, NULL) != 0) return NULL;
  progress.running = 1;
  return &reporter;
}

void cli_progress_stage(const char *fmt, ...) {
  if (!progress.running) return;
  char text[256];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof text, fmt, ap);
  va_end(ap);
  on_progress(NULL, text, -1.0);
}

void cli_progress_done(void) {
  if (!progress.running) return;
  pthread_mutex_lock(&progress.lock);
  progress.stop = 1;
  pthread_cond_signal(&progress.wake);
  pthread_mutex_unlock(&progress.lock);
  pthread_join(progress.thread, NULL);
  progress.running = 0;
}

static void print_warning(void *user, const char *message) {
  (void)user;
  progress_clear();
  fprintf(stderr, "chisel: warning: %s\n", message);
}

ch_error cli_error(void) {
  ch_error err = {0};
  err.warn = print_warning;
  return err;
}

int cli_fail(const ch_error *err) {
  progress_clear();
  fprintf(stderr, "chisel: %s\n", err->message[0] ? err->message : ch_status_name(err->status));
  int code = ch_status_exit_code(err->status);
  return code ? code : 1;
}

int cli_usage_error(const char *cmd, const char *fmt, ...) {
  progress_clear();
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

/* Where a path's file would be: its directory's device and inode, and its
 * name there; and the file's own if it exists. */
typedef struct file_id {
  dev_t dir_dev, dev;
  ino_t dir_ino, ino;
  const char *name;
  int exists;
} file_id;

/* Checks one output and finds its identity; prints one line and returns 2
 * on a problem. */
static int output_id(const char *cmd, const cli_file *o, file_id *id) {
  const char *path = o->path;
  memset(id, 0, sizeof *id);
  if (!path[0]) return cli_usage_error(cmd, "%s: empty output path", o->option);
  const char *slash = strrchr(path, '/');
  char dir[PATH_MAX];
  if (!slash) {
    strcpy(dir, ".");
  } else if (slash == path) {
    strcpy(dir, "/");
  } else {
    size_t n = (size_t)(slash - path);
    if (n >= sizeof dir) return cli_usage_error(cmd, "%s: output path too long", o->option);
    memcpy(dir, path, n);
    dir[n] = '\0';
  }
  id->name = slash ? slash + 1 : path;
  struct stat ds, st;
  if (stat(dir, &ds) != 0 || !S_ISDIR(ds.st_mode) || access(dir, W_OK | X_OK) != 0) {
    int e = errno;
    fprintf(stderr, "chisel: %s: cannot write into directory '%s': %s\n", path, dir,
            strerror(stat(dir, &ds) == 0 && !S_ISDIR(ds.st_mode) ? ENOTDIR : e));
    return 2;
  }
  id->dir_dev = ds.st_dev;
  id->dir_ino = ds.st_ino;
  if (!id->name[0]) {
    fprintf(stderr, "chisel: %s: names a directory, not a file\n", path);
    return 2;
  }
  if (lstat(path, &st) != 0) {
    if (errno == ENOENT) return 0;
    fprintf(stderr, "chisel: %s: cannot check the output: %s\n", path, strerror(errno));
    return 2;
  }
  /* Writing goes to a temporary file renamed over the target: a link
   * would be replaced by a file, a device by a file (as root, /dev/null
   * too). */
  const char *what = S_ISLNK(st.st_mode)   ? "is a symbolic link: chisel replaces files, not links (name the file "
                                             "it points to)"
                     : S_ISDIR(st.st_mode) ? "is a directory, not a file"
                     : !S_ISREG(st.st_mode) ? "is a device, FIFO or socket: chisel writes regular files only"
                     /* (no write bit: read-only by intent, even to root) */
                     : access(path, W_OK) != 0 || !(st.st_mode & (S_IWUSR | S_IWGRP | S_IWOTH))
                         ? "exists and is read-only"
                                               : NULL;
  if (what) {
    fprintf(stderr, "chisel: %s: %s\n", path, what);
    return 2;
  }
  id->exists = 1;
  id->dev = st.st_dev;
  id->ino = st.st_ino;
  return 0;
}

static int same_file(const file_id *a, const file_id *b) {
  if (a->exists && b->exists && a->dev == b->dev && a->ino == b->ino) return 1;
  return a->dir_dev == b->dir_dev && a->dir_ino == b->dir_ino && !strcmp(a->name, b->name);
}

/* A file name whose extension is another format's than the one its option
 * writes (--exr maps.png, chisel sample -o h.png, --glb scene.gltf: a
 * .gltf is JSON by convention): a warning, as the option decides the
 * format and the name is the user's. cmd NULL: any command. */
static void warn_mismatched_name(const char *cmd, const cli_file *f) {
  static const struct {
    const char *cmd, *option, *ext, *format;
  } fixed[] = {{NULL, "--exr", "exr", "an OpenEXR file"},    {NULL, "--png", "png", "a PNG"},
               {NULL, "--height-png", "png", "a PNG"},       {NULL, "--ply", "ply", "a binary PLY"},
               {NULL, "--glb", "glb", "binary glTF (.glb)"}, {"sample", "-o", "exr", "an OpenEXR file"},
               {"dci", "-o", "exr", "an OpenEXR file"},      {"featmap", "-o", "exr", "an OpenEXR file"}};
  static const char *known[] = {"obj", "ply", "glb", "gltf", "exr", "png", "svg", "json"};
  const char *slash = strrchr(f->path, '/'), *dot = strrchr(slash ? slash : f->path, '.');
  if (!dot) return;
  for (size_t i = 0; i < sizeof fixed / sizeof *fixed; i++) {
    if ((fixed[i].cmd && strcmp(cmd, fixed[i].cmd)) || strcmp(f->option, fixed[i].option) ||
        !strcasecmp(dot + 1, fixed[i].ext))
      continue;
    for (size_t k = 0; k < sizeof known / sizeof *known; k++)
      if (!strcasecmp(dot + 1, known[k])) {
        char message[640];
        snprintf(message, sizeof message, "%s %s: writes %s, though the name says .%s", f->option, f->path,
                 fixed[i].format, dot + 1);
        print_warning(NULL, message);
        return;
      }
  }
}

int cli_check_files(const char *cmd, const cli_file *inputs, int num_inputs, const cli_file *outputs,
                    int num_outputs) {
  file_id *ids = calloc((size_t)(num_outputs > 0 ? num_outputs : 1), sizeof *ids);
  if (!ids) {
    fprintf(stderr, "chisel: out of memory\n");
    return 1;
  }
  int rc = 0;
  for (int i = 0; i < num_outputs && !rc; i++) {
    if (!outputs[i].path) continue;
    if ((rc = output_id(cmd, &outputs[i], &ids[i]))) break;
    for (int j = 0; j < i && !rc; j++)
      if (outputs[j].path && same_file(&ids[i], &ids[j]))
        rc = cli_usage_error(cmd, "%s and %s name the same file", outputs[j].option, outputs[i].option);
    /* An input is compared as the file it is (links followed). */
    for (int k = 0; k < num_inputs && !rc && ids[i].exists; k++) {
      struct stat st;
      if (!inputs[k].path || stat(inputs[k].path, &st) != 0) continue; /* its reader will say why */
      if (st.st_dev == ids[i].dev && st.st_ino == ids[i].ino) {
        fprintf(stderr, "chisel: %s: is the input %s (%s): an output never replaces an input\n", outputs[i].path,
                inputs[k].path, inputs[k].option);
        rc = 2;
      }
    }
  }
  for (int i = 0; i < num_outputs && !rc; i++) /* (only for a run that goes on) */
    if (outputs[i].path) warn_mismatched_name(cmd, &outputs[i]);
  free(ids);
  return rc;
}

static const char *signal_name(int sig) {
  return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : sig == SIGHUP ? "SIGHUP" : "a signal";
}

static void *wait_for_signals(void *arg) {
  const sigset_t *set = arg;
  int sig = 0;
  if (sigwait(set, &sig) != 0) return NULL;
  int n = ch_file_remove_temporaries();
  progress_clear();
  fprintf(stderr, "chisel: interrupted by %s%s\n", signal_name(sig),
          n ? "; its temporary files removed, previous files untouched" : "");
  _exit(128 + sig);
}

void cli_signals_init(void) {
  static sigset_t set;
  static const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
  sigemptyset(&set);
  for (size_t i = 0; i < sizeof sigs / sizeof sigs[0]; i++) {
    struct sigaction old;
    if (sigaction(sigs[i], NULL, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    sigaddset(&set, sigs[i]);
  }
  if (pthread_sigmask(SIG_BLOCK, &set, NULL) != 0) return;
  pthread_attr_t attr;
  pthread_t thread;
  int ok = pthread_attr_init(&attr) == 0;
  ok = ok && pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED) == 0 &&
       pthread_create(&thread, &attr, wait_for_signals, &set) == 0;
  pthread_attr_destroy(&attr);
  if (!ok) pthread_sigmask(SIG_UNBLOCK, &set, NULL); /* the default: die without cleaning up */
}

/* The result line waits for cli_run: it says what was written, so it is
 * printed only once the staged outputs are in place. */
static char pending_result[2048];

int cli_run(const cli_command *command, int argc, char **argv) {
  ch_file_stage_begin();
  pending_result[0] = '\0';
  int rc = command->run(argc, argv);
  cli_progress_done();
  if (rc != 0) {
    ch_file_stage_abort();
    return rc;
  }
  ch_error err = cli_error();
  if (ch_file_stage_commit(&err)) return cli_fail(&err);
  if (pending_result[0]) fprintf(stderr, "chisel: %s\n", pending_result);
  return 0;
}

int cli_quiet = 0;
int cli_argc = 0;
char **cli_argv = NULL;

void cli_result(const char *fmt, ...) {
  if (cli_quiet) return;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(pending_result, sizeof pending_result, fmt, ap);
  va_end(ap);
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

unsigned char cli_lit_grey(const double n[3]) {
  static const double L[3] = {-0.35, -0.45, 0.82};
  double l = sqrt(L[0] * L[0] + L[1] * L[1] + L[2] * L[2]);
  double d = (n[0] * L[0] + n[1] * L[1] + n[2] * L[2]) / l;
  double h[3] = {L[0] / l, L[1] / l, L[2] / l + 1.0}, hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
  double s = pow(fmax(0.0, (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]) / hl), 40.0);
  double v = 0.75 * (0.15 + 0.85 * fmax(0.0, d)) + 0.25 * s;
  v = pow(fmin(fmax(v, 0.0), 1.0), 1.0 / 2.2);
  return (unsigned char)lround(255.0 * v);
}
