#include "ch_error.h"

#include <stdarg.h>
#include <stdio.h>

ch_status ch_error_set(ch_error *err, ch_status status, const char *fmt, ...) {
  if (!err) return status;
  err->status = status;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(err->message, sizeof err->message, fmt, ap);
  va_end(ap);
  return status;
}

void ch_warn(ch_error *err, const char *fmt, ...) {
  if (!err) return;
  err->num_warnings++;
  if (!err->warn) return;
  char buf[CH_ERROR_MESSAGE_MAX];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(buf, sizeof buf, fmt, ap);
  va_end(ap);
  err->warn(err->warn_user, buf);
}

int ch_status_exit_code(ch_status status) {
  switch (status) {
  case CH_OK: return 0;
  case CH_ERR_INPUT:
  case CH_ERR_IO: return 2;
  default: return 1;
  }
}

const char *ch_status_name(ch_status status) {
  switch (status) {
  case CH_OK: return "ok";
  case CH_ERR_INPUT: return "bad input";
  case CH_ERR_IO: return "i/o error";
  case CH_ERR_NOMEM: return "out of memory";
  case CH_ERR_INTERNAL: return "internal error";
  case CH_ERR_WRITE:
    return "write error";
  }
  return "unknown status";
}
