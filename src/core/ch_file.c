#define _POSIX_C_SOURCE 200809L
#include "ch_file.h"

#include <ctype.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char *dup_string(const char *s) {
  size_t n = strlen(s) + 1;
  char *d = malloc(n);
  if (d) memcpy(d, s, n);
  return d;
}

ch_status ch_atomic_open(ch_atomic_file *f, const char *path, ch_error *err) {
  memset(f, 0, sizeof *f);
  size_t n = strlen(path);
  f->final_path = dup_string(path);
  f->temp_path = malloc(n + 16);
  if (!f->final_path || !f->temp_path) {
    ch_atomic_abort(f);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  }
  memcpy(f->temp_path, path, n);
  memcpy(f->temp_path + n, ".tmp.XXXXXX", 12);
  int fd = mkstemp(f->temp_path);
  if (fd < 0) {
    int e = errno;
    free(f->temp_path);
    f->temp_path = NULL;
    ch_atomic_abort(f);
    return ch_error_set(err, CH_ERR_IO, "%s: cannot create file: %s", path, strerror(e));
  }
  /* mkstemp creates 0600; give the file the usual permissions. */
  mode_t mask = umask(0);
  umask(mask);
  fchmod(fd, 0666 & ~mask);
  f->fp = fdopen(fd, "wb");
  if (!f->fp) {
    close(fd);
    ch_atomic_abort(f);
    return ch_error_set(err, CH_ERR_IO, "%s: cannot open stream", path);
  }
  return CH_OK;
}

ch_status ch_atomic_commit(ch_atomic_file *f, ch_error *err) {
  const char *path = f->final_path ? f->final_path : "(output)";
  int failed = !f->fp || ferror(f->fp);
  int e = errno;
  if (f->fp) {
    if (fflush(f->fp) != 0) { failed = 1; e = errno; }
    if (fclose(f->fp) != 0) { failed = 1; e = errno; }
    f->fp = NULL;
  }
  if (!failed && rename(f->temp_path, f->final_path) != 0) { failed = 1; e = errno; }
  if (failed) {
    ch_error_set(err, CH_ERR_IO, "%s: cannot write file: %s", path, strerror(e));
    ch_atomic_abort(f);
    return CH_ERR_IO;
  }
  free(f->temp_path);
  free(f->final_path);
  memset(f, 0, sizeof *f);
  return CH_OK;
}

void ch_atomic_abort(ch_atomic_file *f) {
  if (f->fp) fclose(f->fp);
  if (f->temp_path) remove(f->temp_path);
  free(f->temp_path);
  free(f->final_path);
  memset(f, 0, sizeof *f);
}

ch_status ch_file_read_all(const char *path, size_t max_size, char **data,
                           size_t *size, ch_error *err) {
  *data = NULL;
  *size = 0;
  FILE *fp = fopen(path, "rb");
  if (!fp) return ch_error_set(err, CH_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  struct stat st;
  if (fstat(fileno(fp), &st) != 0 || !S_ISREG(st.st_mode)) {
    fclose(fp);
    return ch_error_set(err, CH_ERR_IO, "%s: not a regular file", path);
  }
  if ((unsigned long long)st.st_size > max_size) {
    fclose(fp);
    return ch_error_set(err, CH_ERR_INPUT, "%s: file too large (%lld bytes, limit %zu)",
                        path, (long long)st.st_size, max_size);
  }
  size_t n = (size_t)st.st_size;
  char *buf = malloc(n + 1);
  if (!buf) {
    fclose(fp);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  }
  size_t got = fread(buf, 1, n, fp);
  int bad = ferror(fp);
  fclose(fp);
  if (bad || got != n) {
    free(buf);
    return ch_error_set(err, CH_ERR_IO, "%s: read error", path);
  }
  buf[n] = '\0';
  *data = buf;
  *size = n;
  return CH_OK;
}

void ch_path_extension(const char *path, char *out, size_t out_size) {
  if (out_size == 0) return;
  out[0] = '\0';
  const char *slash = strrchr(path, '/');
  const char *base = slash ? slash + 1 : path;
  const char *dot = strrchr(base, '.');
  if (!dot || dot == base) return;
  size_t i = 0;
  for (const char *p = dot + 1; *p && i + 1 < out_size; p++) out[i++] = (char)tolower((unsigned char)*p);
  out[i] = '\0';
}
