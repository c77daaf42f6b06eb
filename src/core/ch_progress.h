/* ch_progress: how far a long job has come. The library reports through a
 * callback what it is doing and, where it knows, the fraction of that done;
 * whoever runs the job decides what to show (the command line draws one
 * line on a terminal once a run has taken 2 s). Library code never prints:
 * a NULL ch_progress, or one without a callback, reports nothing. */
#ifndef CH_PROGRESS_H
#define CH_PROGRESS_H

#ifdef __cplusplus
extern "C" {
#endif

/* stage: what is being done, one short line ("feature embedding, run 2 of
 * up to 8: refinement round 3, crossings"), valid only during the call;
 * fraction: how much of that stage is done, in [0, 1], or negative when
 * unknown. */
typedef void (*ch_progress_fn)(void *user, const char *stage, double fraction);

typedef struct ch_progress {
  ch_progress_fn fn; /* called from the thread that runs the job, one call at a time */
  void *user;
} ch_progress;

/* Reports a stage to p (NULL: nothing). */
void ch_progress_report(const ch_progress *p, const char *stage, double fraction);

/* The same with a printf-style stage (at most 255 bytes kept). */
void ch_progress_reportf(const ch_progress *p, double fraction, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* A monotonic wall clock in seconds (any origin), for the time a stage
 * took in statistics. Thread safe. */
double ch_progress_seconds(void);

#ifdef __cplusplus
}
#endif
#endif
