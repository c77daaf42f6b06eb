/* ch_error: status codes and the error/warning record every chisel function
 * fills. Library code never prints and never exits; it returns a status and
 * leaves one line (file, element, reason) in the record. The CLI prints it. */
#ifndef CH_ERROR_H
#define CH_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum ch_status {
  CH_OK = 0,
  CH_ERR_INPUT,    /* malformed or unusable input: exit status 2 */
  CH_ERR_IO,       /* a file cannot be opened, read or created: exit status 2 */
  CH_ERR_NOMEM,    /* allocation failed: exit status 1 */
  CH_ERR_INTERNAL, /* a bug or a library failure: exit status 1 */
  CH_ERR_WRITE     /* the system failed a write (a full disk or quota, a file
                      over the size limit, a device error): exit status 1,
                      as nothing the user gave is wrong */
} ch_status;

enum { CH_ERROR_MESSAGE_MAX = 1024 };

/* Warnings are passed to an optional sink (the CLI prints them to stderr);
 * without one they are counted and dropped. */
typedef void (*ch_warning_fn)(void *user, const char *message);

typedef struct ch_error {
  ch_status status;
  char message[CH_ERROR_MESSAGE_MAX];
  ch_warning_fn warn;
  void *warn_user;
  int num_warnings;
} ch_error;

/* Records status and a printf-style message (truncated to fit); returns the
 * status so callers can `return ch_error_set(err, ...)`. err may be NULL. */
ch_status ch_error_set(ch_error *err, ch_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Passes a warning to err->warn (if any) and counts it. err may be NULL. */
void ch_warn(ch_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* The process exit status docs/spec.md §5 gives for a status: 0, 1 or 2. */
int ch_status_exit_code(ch_status status);

/* A short name for a status ("bad input", "out of memory", ...). */
const char *ch_status_name(ch_status status);

#ifdef __cplusplus
}
#endif
#endif
