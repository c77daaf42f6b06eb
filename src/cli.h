/* The chisel command line: shared helpers of the subcommands. */
#ifndef CH_CLI_H
#define CH_CLI_H

#include <stddef.h>

#include "ch_error.h"
#include "ch_progress.h"

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

/* -q/--quiet (main.c): no result line and no notes; warnings and errors
 * still go to stderr. */
extern int cli_quiet;

/* The command line as typed (main.c sets them before a command runs), for
 * reports that say what made them. */
extern int cli_argc;
extern char **cli_argv;

/* The one line every successful run ends with, "chisel: MESSAGE", on
 * stderr (stdout may carry data: -o -, --json); nothing with -q. Held
 * until cli_run has moved the staged outputs into place, so it never
 * announces files a failed commit took back. */
void cli_result(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

/* Whether an output path names standard output ("-"). */
int cli_is_stdout(const char *path);

/* Refuses -o - (or another option's "-") for a format that cannot be
 * streamed: prints a usage error naming the option and returns 2. */
int cli_refuse_stdout(const char *cmd, const char *option, const char *format);

/* The candidate nearest to word in edit distance (adjacent swaps count
 * one), or NULL when none is close enough to be a typing slip. */
const char *cli_suggest(const char *word, const char *const *candidates, int n);

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

/* Parses --fill-height H (nonzero, finite) into desc; on failure prints a
 * usage error and returns nonzero. */
struct ch_svg_desc;
int cli_parse_fill_height(const char *cmd, const char *text, struct ch_svg_desc *desc);

/* Whether argv[i] asks for help (-h, --help). */
int cli_is_help(const char *arg);

/* A file named on the command line: what named it (an option such as
 * "--ply", or the operand's name such as "BASE.obj") and its path (NULL:
 * not given, skipped). */
typedef struct cli_file {
  const char *option;
  const char *path;
} cli_file;

/* Checks a command's files before any work, so nothing is lost and no time
 * is wasted: every output's directory exists and is writable; no output is
 * a symbolic link, a directory, a device, FIFO or socket, or an existing
 * read-only file; no output is one of the inputs, or another output (the
 * same file by device and inode, through links and relative paths, or the
 * same name in the same directory). On the first problem prints one line
 * and returns 2; otherwise 0. */
int cli_check_files(const char *cmd, const cli_file *inputs, int num_inputs, const cli_file *outputs,
                    int num_outputs);

/* Makes SIGINT, SIGTERM and SIGHUP end the run cleanly: a thread waits for
 * them, removes every temporary file (ch_file_remove_temporaries), prints
 * one line and exits with 128 + the signal (130, 143, 129). Signals the
 * process inherited as ignored (nohup, background jobs) stay ignored. Call
 * first in main, before any other thread exists (they inherit the blocked
 * mask). */
void cli_signals_init(void);

/* Progress on a terminal: from cli_progress_start until cli_progress_done,
 * once the run has taken 2 s, one line on stderr redrawn in place four
 * times a second with the latest stage (the CLI's own, cli_progress_stage,
 * or the library's through the returned ch_progress), how far it is when
 * known, and the time so far. Nothing when stderr is not a terminal (then
 * NULL is returned, which library calls take as no reports). Warnings and
 * errors printed through cli_* clear the line first. */
const ch_progress *cli_progress_start(const char *cmd);
void cli_progress_stage(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;
void cli_progress_done(void);

/* Runs a command with its outputs staged (ch_file): they are written as
 * temporaries and moved into place together when it returns 0; a failure
 * (or a failed move) removes them, so a run's outputs appear all together
 * or not at all and previous files stay as they were. Returns the exit
 * status. */
int cli_run(const cli_command *command, int argc, char **argv);

/* A unit normal lit by the study's default light (ch_render: ambient
 * 0.15, albedo 0.75, specular 0.25, shininess 40, seen from straight
 * above, light from the upper left) as an sRGB grey: previews of normals. */
unsigned char cli_lit_grey(const double n[3]);

#endif
