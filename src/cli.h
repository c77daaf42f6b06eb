/* The chisel command line: shared helpers of the subcommands. */
#ifndef CH_CLI_H
#define CH_CLI_H

#include "ch_error.h"

typedef struct cli_command {
  const char *name;
  const char *summary;  /* one line for `chisel --help` */
  const char *usage;    /* full help text for `chisel help NAME` */
  int (*run)(int argc, char **argv);  /* argv[0] is the command name */
} cli_command;

extern const cli_command cli_info_command;
extern const cli_command cli_sample_command;
extern const cli_command cli_dci_command;
extern const cli_command cli_magnify_command;
extern const cli_command cli_displace_command;
extern const cli_command cli_study_command;
extern const cli_command cli_featmap_command;

/* Prints "chisel: message" and returns the exit status of err's status. */
int cli_fail(const ch_error *err);

/* Prints "chisel CMD: message" for usage errors and returns 2. */
int cli_usage_error(const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* A ch_error whose warnings go to stderr as "chisel: warning: ...". */
ch_error cli_error(void);

/* Parses an integer option value within [lo, hi]; on failure prints a usage
 * error and returns nonzero. */
int cli_parse_int(const char *cmd, const char *option, const char *text, long lo, long hi,
                  long *out);

/* Parses exactly n comma-separated finite numbers; on failure prints a
 * usage error and returns nonzero. */
int cli_parse_doubles(const char *cmd, const char *option, const char *text, int n, double *out);

/* Fetches the value of option argv[*i] (advancing *i); NULL and a usage
 * error if it is missing. */
const char *cli_option_value(const char *cmd, int argc, char **argv, int *i);

/* Whether argv[i] asks for help (-h, --help). */
int cli_is_help(const char *arg);

/* Output files written by a command, so a failure after the first one can
 * remove what was written: all outputs or none. */
typedef struct cli_outputs {
  const char *paths[8];
  int count;
} cli_outputs;

/* Checks that path's directory exists and is writable (before any work). */
int cli_check_output(const char *cmd, const char *option, const char *path);
void cli_outputs_add(cli_outputs *outs, const char *path);
void cli_outputs_remove_all(cli_outputs *outs);

#endif
