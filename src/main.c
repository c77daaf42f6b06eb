/* chisel: vector features drawn in texture space -> crisp displaced
 * geometry. This file dispatches the subcommands (SPEC §5). */
#include <stdio.h>
#include <string.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "cli.h"

#ifndef CHISEL_VERSION
#define CHISEL_VERSION "unknown"
#endif

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
          CHISEL_VERSION);
  for (int i = 0; i < NUM_COMMANDS; i++)
    fprintf(out, "  %-10s %s\n", commands[i]->name, commands[i]->summary);
  fprintf(out,
          "  %-10s %s\n"
          "\n"
          "`chisel COMMAND --help` describes a command. Exit status: 0 success,\n"
          "2 bad input or usage (one line on stderr), 1 internal failure.\n",
          "help", "help on a command");
}

static const cli_command *find_command(const char *name) {
  for (int i = 0; i < NUM_COMMANDS; i++)
    if (!strcmp(commands[i]->name, name)) return commands[i];
  return NULL;
}

int main(int argc, char **argv) {
#ifdef __GLIBC__
  /* The stages allocate and free arrays of hundreds of MB, round after
   * round. glibc serves those with fresh mmap()s, which the kernel zeroes
   * page by page (a fifth of a 2M-triangle run); from the heap, kept,
   * they are reused instead. */
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
  if (argc < 2) {
    print_overview(stderr);
    return 2;
  }
  const char *name = argv[1];
  if (cli_is_help(name)) {
    print_overview(stdout);
    return 0;
  }
  if (!strcmp(name, "--version")) {
    printf("chisel %s\n", CHISEL_VERSION);
    return 0;
  }
  if (!strcmp(name, "help")) {
    if (argc < 3) {
      print_overview(stdout);
      return 0;
    }
    const cli_command *c = find_command(argv[2]);
    if (!c) {
      fprintf(stderr, "chisel: unknown command '%s' (see chisel --help)\n", argv[2]);
      return 2;
    }
    fputs(c->usage, stdout);
    return 0;
  }
  const cli_command *c = find_command(name);
  if (!c) {
    fprintf(stderr, "chisel: unknown command '%s' (see chisel --help)\n", name);
    return 2;
  }
  for (int i = 2; i < argc; i++) {
    if (!strcmp(argv[i], "--")) break;
    if (cli_is_help(argv[i])) {
      fputs(c->usage, stdout);
      return 0;
    }
  }
  return c->run(argc - 1, argv + 1);
}
