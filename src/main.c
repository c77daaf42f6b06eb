/* chisel: vector features drawn in texture space -> crisp displaced
 * geometry. This file dispatches the subcommands (docs/spec.md §5). */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "ch_version.h"
#include "cli.h"

static const cli_command *commands[] = {&cli_displace_command, &cli_info_command, &cli_sample_command,
                                        &cli_dci_command, &cli_featmap_command, &cli_magnify_command,
                                        &cli_study_command};
enum { NUM_COMMANDS = sizeof commands / sizeof commands[0] };

static void print_overview(FILE *out) {
  fprintf(out,
          "chisel %s: vector features in texture space -> crisp displaced geometry\n"
          "\n"
          "usage: chisel COMMAND [options]\n"
          "\n"
          "commands:\n",
          CH_VERSION_STRING);
  for (int i = 0; i < NUM_COMMANDS; i++)
    fprintf(out, "  %-10s %s\n", commands[i]->name, commands[i]->summary);
  fprintf(out,
          "  %-10s %s\n"
          "\n"
          "options every command takes:\n"
          "  -q, --quiet        no result line and no notes on stderr (warnings and\n"
          "                     errors still)\n"
          "  -j, --threads N    use N threads (default: OMP_NUM_THREADS, else every core);\n"
          "                     the output is the same for any N\n"
          "  --opt=value        the same as --opt value\n"
          "\n"
          "`chisel COMMAND --help` describes a command. Every successful run ends with\n"
          "one line on stderr saying what it wrote, how big and how long it took.\n"
          "Exit status: 0 success, 2 bad input or usage (one line on stderr), 1\n"
          "internal failure.\n",
          "help", "help on a command");
}

/* Every option a command takes, space-separated, a trailing '=' on those
 * that take a value. prepare_args uses it to split --opt=value, to take an
 * option's value whatever it looks like (-o -, --camera -1,2,...) and to
 * answer a mistyped option with the nearest one. A command not listed
 * here has its options checked by its own parser only. */
static const struct {
  const char *command, *options;
} option_lists[] = {
    {"displace", "-o= --output= --target-tris= --max-tris= --res= --scheme= --no-snap --snap-to= --camera= --warp-dci --exr= --glb= "
                 "--png= --height-png= --ply= --stats --json --fill-height="},
    {"info", "--json --fill-height="},
    {"sample", "-o= --output= --res= --supersample= --png= --height-png= --fill-height="},
    {"dci", "-o= --output= --res= --rect= --png= --stats --fill-height="},
    {"featmap", "-o= --output= --res= --dci-res= --rect= --png= --linear --no-fallback --stats --fill-height="},
    {"magnify", "-o= --output= --rect= --out-res= --method= --curves= --no-aa --exr= --fill-height="},
    {"study", "-o= --output="},
};

static const char *options_of(const cli_command *c) {
  for (size_t i = 0; i < sizeof option_lists / sizeof option_lists[0]; i++)
    if (!strcmp(option_lists[i].command, c->name)) return option_lists[i].options;
  return NULL;
}

static const cli_command *find_command(const char *name) {
  for (int i = 0; i < NUM_COMMANDS; i++)
    if (!strcmp(commands[i]->name, name)) return commands[i];
  return NULL;
}

static int unknown_command(const char *name) {
  const char *names[NUM_COMMANDS + 1];
  for (int i = 0; i < NUM_COMMANDS; i++) names[i] = commands[i]->name;
  names[NUM_COMMANDS] = "help";
  const char *near = cli_suggest(name, names, NUM_COMMANDS + 1);
  if (near)
    fprintf(stderr, "chisel: unknown command '%s' (did you mean '%s'? see chisel --help)\n", name, near);
  else
    fprintf(stderr, "chisel: unknown command '%s' (see chisel --help)\n", name);
  return 2;
}

/* The command's options as listed in c->options: 1 with a value, 0 a flag,
 * -1 unknown (then *near is the nearest name, or NULL). */
static int option_kind(const cli_command *c, const char *name, size_t len, const char **near, char *store,
                       size_t store_size) {
  const char *list = options_of(c);
  const char *names[128];
  int n = 0;
  size_t used = 0;
  while (*list) {
    while (*list == ' ') list++;
    size_t k = strcspn(list, " ");
    if (!k) break;
    int takes = list[k - 1] == '=';
    size_t nk = k - (size_t)takes;
    if (nk == len && !strncmp(list, name, len)) return takes;
    if (n < 128 && used + nk + 1 <= store_size) {
      memcpy(store + used, list, nk);
      store[used + nk] = '\0';
      names[n++] = store + used;
      used += nk + 1;
    }
    list += k;
  }
  char word[128];
  snprintf(word, sizeof word, "%.*s", (int)(len < 127 ? len : 127), name);
  *near = cli_suggest(word, names, n);
  return -1;
}

static int parse_threads(const char *cmd, const char *option, const char *text) {
  long n;
  if (cli_parse_int(cmd, option, text, 1, 1024, &n)) return 2;
  omp_set_num_threads((int)n);
  return 0;
}

/* The options every command shares (-q, -j) are taken out here, and
 * --opt=value becomes --opt value, so each command parses one form. The
 * new argv (args, n) points into argv and into owned, which the caller
 * frees. Returns 0, or the exit status of a usage error (printed). */
static int prepare_args(const cli_command *c, int argc, char **argv, char **args, int *n, char **owned,
                        int *num_owned) {
  const char *cmd = c->name;
  char store[4096];
  *n = 0;
  args[(*n)++] = argv[0];
  int rest = 0; /* after "--": every argument is a name */
  for (int i = 1; i < argc; i++) {
    char *a = argv[i];
    if (rest || a[0] != '-' || !a[1]) {
      args[(*n)++] = a;
      continue;
    }
    if (!strcmp(a, "--")) {
      rest = 1;
      args[(*n)++] = a;
      continue;
    }
    if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
      cli_quiet = 1;
      continue;
    }
    if (!strcmp(a, "-j") || !strcmp(a, "--threads")) {
      if (i + 1 >= argc) return cli_usage_error(cmd, "option %s needs a value", a);
      if (parse_threads(cmd, a, argv[++i])) return 2;
      continue;
    }
    if (!strncmp(a, "--threads=", 10)) {
      if (parse_threads(cmd, "--threads", a + 10)) return 2;
      continue;
    }
    if (a[1] == 'j' && a[2] >= '0' && a[2] <= '9') { /* -j4 */
      if (parse_threads(cmd, "-j", a + 2)) return 2;
      continue;
    }
    const char *eq = a[1] == '-' ? strchr(a, '=') : NULL;
    size_t len = eq ? (size_t)(eq - a) : strlen(a);
    if (!options_of(c)) { /* unchecked: split --opt=value all the same */
      if (eq) {
        char *name = malloc(len + 1);
        if (!name) return cli_usage_error(cmd, "out of memory");
        memcpy(name, a, len);
        name[len] = '\0';
        owned[(*num_owned)++] = name;
        args[(*n)++] = name;
        args[(*n)++] = (char *)eq + 1;
      } else {
        args[(*n)++] = a;
      }
      continue;
    }
    const char *near = NULL;
    int kind = option_kind(c, a, len, &near, store, sizeof store);
    if (kind < 0) {
      if (near) return cli_usage_error(cmd, "unknown option '%.*s' (did you mean %s?)", (int)len, a, near);
      return cli_usage_error(cmd, "unknown option '%.*s'", (int)len, a);
    }
    if (eq && !kind) return cli_usage_error(cmd, "option %.*s takes no value", (int)len, a);
    if (eq) {
      char *name = malloc(len + 1);
      if (!name) return cli_usage_error(cmd, "out of memory");
      memcpy(name, a, len);
      name[len] = '\0';
      owned[(*num_owned)++] = name;
      args[(*n)++] = name;
      args[(*n)++] = (char *)eq + 1;
    } else {
      args[(*n)++] = a;
      /* The value is the next argument whatever it looks like. */
      if (kind && i + 1 < argc) args[(*n)++] = argv[++i];
    }
  }
  args[*n] = NULL;
  return 0;
}

int main(int argc, char **argv) {
  cli_signals_init(); /* before any thread: they inherit its mask */
#ifdef __GLIBC__
  /* The stages allocate and free arrays of hundreds of MB, round after
   * round. glibc serves those with fresh mmap()s, which the kernel zeroes
   * page by page (a fifth of a 2M-triangle run); from the heap, kept,
   * they are reused instead. One arena for all threads: memory a worker
   * thread frees in its own arena is never reused by the main thread's
   * arrays, which then take pages the kernel must first zero (plane +
   * ornament at 2.1M triangles: peak 365 -> 312 MB; 2-15% lower on every
   * bundled set at 520k and 2.1M, and the same user time: the big arrays
   * are few and the small ones rarely contend with 2 threads). */
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  mallopt(M_ARENA_MAX, 1);
#endif
  if (argc < 2) {
    print_overview(stderr);
    return 2;
  }
  cli_argc = argc, cli_argv = argv;
  const char *name = argv[1];
  if (cli_is_help(name)) {
    print_overview(stdout);
    return 0;
  }
  if (!strcmp(name, "--version")) {
    printf("chisel %s\n", CH_VERSION_STRING);
    return 0;
  }
  if (!strcmp(name, "help")) {
    if (argc < 3) {
      print_overview(stdout);
      return 0;
    }
    const cli_command *c = find_command(argv[2]);
    if (!c) return unknown_command(argv[2]);
    fputs(c->usage, stdout);
    return 0;
  }
  const cli_command *c = find_command(name);
  if (!c) return unknown_command(name);
  for (int i = 2; i < argc; i++) {
    if (!strcmp(argv[i], "--")) break;
    if (cli_is_help(argv[i])) {
      fputs(c->usage, stdout);
      return 0;
    }
  }
  /* At most one more argument per --opt=value, plus the NULL. */
  char **args = malloc(((size_t)argc * 2 + 1) * sizeof *args);
  char **owned = malloc(((size_t)argc + 1) * sizeof *owned);
  int n = 0, num_owned = 0, rc;
  if (!args || !owned) {
    fprintf(stderr, "chisel: out of memory\n");
    rc = 1;
  } else {
    rc = prepare_args(c, argc - 1, argv + 1, args, &n, owned, &num_owned);
    if (!rc) rc = cli_run(c, n, args);
  }
  for (int i = 0; i < num_owned; i++) free(owned[i]);
  free(owned);
  free(args);
  return rc;
}
