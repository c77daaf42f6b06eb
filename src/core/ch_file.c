/* Output files (see ch_file.h). The temporaries' stream is a stdio
 * cookie stream over the file descriptor (glibc's fopencookie), so the
 * first failed write keeps its errno whichever writer made it (the EXR,
 * PNG and mesh writers' own messages say only "write error"). */
#define _GNU_SOURCE
#include "ch_file.h"

#include "ch_alloc.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

struct ch_temp_entry {
  ch_temp_entry *prev, *next;
  char *temp_path, *final_path;
  int fd;          /* -1 once closed */
  int write_errno; /* the first failed write's */
  int staged;      /* complete, waiting for ch_file_stage_commit */
  int done;        /* during a commit: how it went into place */
};

enum { DONE_NOT = 0, DONE_EXCHANGED, DONE_CREATED, DONE_REPLACED, DONE_KEPT };

static pthread_mutex_t list_lock = PTHREAD_MUTEX_INITIALIZER;
static ch_temp_entry *list_head, *list_tail;
static int staging, closed_down, mode_known;
static mode_t file_mode;

/* (under list_lock) */
static void list_add(ch_temp_entry *e) {
  e->prev = list_tail;
  e->next = NULL;
  if (list_tail) list_tail->next = e;
  else list_head = e;
  list_tail = e;
}

static void list_remove(ch_temp_entry *e) {
  if (e->prev) e->prev->next = e->next;
  else list_head = e->next;
  if (e->next) e->next->prev = e->prev;
  else list_tail = e->prev;
  e->prev = e->next = NULL;
}

static void free_entry(ch_temp_entry *e) {
  if (!e) return;
  if (e->fd >= 0) close(e->fd);
  free(e->temp_path);
  free(e->final_path);
  free(e);
}

static char *dup_string(const char *s) {
  size_t n = strlen(s) + 1;
  char *d = malloc(n);
  if (d) memcpy(d, s, n);
  return d;
}

ch_status ch_file_error(ch_error *err, const char *path, const char *what, int code) {
  ch_status st = code == ENOSPC || code == EDQUOT || code == EFBIG || code == EIO ? CH_ERR_WRITE : CH_ERR_IO;
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 32))
  const char *name = strerrorname_np(code);
  if (name) return ch_error_set(err, st, "%s: %s: %s (%s)", path, what, strerror(code), name);
#endif
  return ch_error_set(err, st, "%s: %s: %s", path, what, strerror(code));
}

/* The cookie stream's write: the whole buffer, or 0 with the errno kept. */
static ssize_t cookie_write(void *cookie, const char *buf, size_t size) {
  ch_temp_entry *e = cookie;
  size_t done = 0;
  while (done < size) {
    ssize_t n = e->fd >= 0 ? write(e->fd, buf + done, size - done) : -1;
    if (n > 0) {
      done += (size_t)n;
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (!e->write_errno) e->write_errno = n < 0 && e->fd >= 0 ? errno : EIO;
    break;
  }
  return (ssize_t)done;
}

/* The EXR writer goes back to fill in its offset table. */
static int cookie_seek(void *cookie, off64_t *offset, int whence) {
  ch_temp_entry *e = cookie;
  off_t r = e->fd >= 0 ? lseek(e->fd, (off_t)*offset, whence) : -1;
  if (r < 0) return -1;
  *offset = (off64_t)r;
  return 0;
}

/* Some file systems (NFS) report a full disk only when the file closes. */
static int cookie_close(void *cookie) {
  ch_temp_entry *e = cookie;
  if (e->fd < 0) return 0;
  int r = close(e->fd);
  if (r != 0 && !e->write_errno) e->write_errno = errno;
  e->fd = -1;
  return r == 0 ? 0 : EOF;
}

/* Splits path into its directory (into dir) and its last component. */
static const char *split_path(const char *path, char *dir, size_t dir_size) {
  const char *slash = strrchr(path, '/');
  if (!slash) {
    snprintf(dir, dir_size, ".");
    return path;
  }
  size_t n = slash == path ? 1 : (size_t)(slash - path);
  if (n >= dir_size) return NULL;
  memcpy(dir, path, n);
  dir[n] = '\0';
  return slash + 1;
}

/* Temporaries of path's left by runs that are gone: named
 * BASE.tmp.chisel-PID-XXXXXX, PID not a live process, a regular file of
 * ours that no process holds locked (the writer holds an flock while it
 * writes, which also covers another machine's run on a shared disk). */
static void remove_stale(const char *path, ch_error *err) {
  char dir[PATH_MAX], prefix[NAME_MAX + 32], full[PATH_MAX];
  const char *base = split_path(path, dir, sizeof dir);
  if (!base || !base[0]) return;
  int plen = snprintf(prefix, sizeof prefix, "%s.tmp.chisel-", base);
  if (plen < 0 || (size_t)plen >= sizeof prefix) return;
  DIR *d = opendir(dir);
  if (!d) return;
  for (struct dirent *de; (de = readdir(d));) {
    const char *name = de->d_name;
    if (strncmp(name, prefix, (size_t)plen) != 0) continue;
    const char *p = name + plen;
    char *end;
    errno = 0;
    long pid = strtol(p, &end, 10);
    if (end == p || *end != '-' || pid <= 0 || errno || strlen(end + 1) != 6) continue;
    int ok = 1;
    for (const char *c = end + 1; *c; c++) ok &= isalnum((unsigned char)*c) != 0;
    if (!ok || pid == (long)getpid()) continue;
    if (kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue; /* alive, or not ours to ask */
    if (snprintf(full, sizeof full, "%s/%s", dir, name) >= (int)sizeof full) continue;
    int fd = open(full, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) continue;
    struct stat st, now;
    if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_uid == geteuid() && flock(fd, LOCK_EX | LOCK_NB) == 0 &&
        lstat(full, &now) == 0 && now.st_dev == st.st_dev && now.st_ino == st.st_ino && unlink(full) == 0)
      ch_warn(err, "%s: removed %s, left by an interrupted run (process %ld)", path, name, pid);
    close(fd);
  }
  closedir(d);
}

ch_status ch_atomic_open(ch_atomic_file *f, const char *path, ch_error *err) {
  memset(f, 0, sizeof *f);
  if (!path || !path[0]) return ch_error_set(err, CH_ERR_IO, "(output): empty path");
  remove_stale(path, err);
  size_t n = strlen(path);
  ch_temp_entry *e = calloc(1, sizeof *e);
  if (e) {
    e->fd = -1;
    e->final_path = dup_string(path);
    e->temp_path = malloc(n + 48);
  }
  if (!e || !e->final_path || !e->temp_path) {
    free_entry(e);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  }
  snprintf(e->temp_path, n + 48, "%s.tmp.chisel-%ld-XXXXXX", path, (long)getpid());
  pthread_mutex_lock(&list_lock);
  if (closed_down) {
    pthread_mutex_unlock(&list_lock);
    free_entry(e);
    return ch_error_set(err, CH_ERR_IO, "%s: not written: the run is being interrupted", path);
  }
  if (!mode_known) { /* umask can only be read by setting it: once, under the lock */
    mode_t mask = umask(0);
    umask(mask);
    file_mode = 0666 & ~mask;
    mode_known = 1;
  }
  e->fd = mkostemp(e->temp_path, O_CLOEXEC);
  int code = errno;
  if (e->fd >= 0) list_add(e);
  pthread_mutex_unlock(&list_lock);
  if (e->fd < 0) {
    free_entry(e);
    return ch_file_error(err, path, "cannot create file", code);
  }
  (void)flock(e->fd, LOCK_EX | LOCK_NB); /* tells a later run it is in use (see remove_stale) */
  (void)fchmod(e->fd, file_mode);        /* mkostemp creates 0600 */
  cookie_io_functions_t io = {.write = cookie_write, .seek = cookie_seek, .close = cookie_close};
  f->fp = fopencookie(e, "wb", io);
  f->temp = e;
  f->final_path = e->final_path;
  f->temp_path = e->temp_path;
  if (!f->fp) {
    ch_atomic_abort(f);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  }
  setvbuf(f->fp, NULL, _IOFBF, 1 << 16);
  return CH_OK;
}

int ch_atomic_errno(const ch_atomic_file *f) { return f && f->temp ? f->temp->write_errno : 0; }

/* Unlists e, removes its file and frees it. */
static void discard(ch_temp_entry *e) {
  pthread_mutex_lock(&list_lock);
  unlink(e->temp_path);
  list_remove(e);
  pthread_mutex_unlock(&list_lock);
  free_entry(e);
}

ch_status ch_atomic_commit(ch_atomic_file *f, ch_error *err) {
  ch_temp_entry *e = f->temp;
  if (!e) return ch_error_set(err, CH_ERR_IO, "(output): not open");
  int failed = !f->fp || ferror(f->fp);
  if (f->fp) {
    if (fflush(f->fp) != 0) failed = 1;
    if (fclose(f->fp) != 0) failed = 1;
    f->fp = NULL;
  }
  memset(f, 0, sizeof *f);
  if (failed || e->write_errno) {
    ch_status st = ch_file_error(err, e->final_path, "cannot write", e->write_errno ? e->write_errno : EIO);
    discard(e);
    return st;
  }
  pthread_mutex_lock(&list_lock);
  if (staging) {
    e->staged = 1;
    pthread_mutex_unlock(&list_lock);
    return CH_OK;
  }
  int r = rename(e->temp_path, e->final_path), code = errno;
  if (r != 0) unlink(e->temp_path);
  list_remove(e);
  pthread_mutex_unlock(&list_lock);
  ch_status st = r ? ch_file_error(err, e->final_path, "cannot move the finished file into place", code) : CH_OK;
  free_entry(e);
  return st;
}

void ch_atomic_abort(ch_atomic_file *f) {
  if (f->fp) fclose(f->fp);
  if (f->temp) discard(f->temp);
  memset(f, 0, sizeof *f);
}

ch_status ch_atomic_fail(ch_atomic_file *f, ch_status st, ch_error *err) {
  if (f->fp) fflush(f->fp); /* a write error may still sit in the buffer */
  if (f->temp && f->temp->write_errno)
    st = ch_file_error(err, f->temp->final_path, "cannot write", f->temp->write_errno);
  ch_atomic_abort(f);
  return st;
}

void ch_file_stage_begin(void) {
  pthread_mutex_lock(&list_lock);
  staging = 1;
  pthread_mutex_unlock(&list_lock);
}

/* Moves e's temporary into place (under list_lock): exchanged with the
 * previous file where there is one (so it can be put back), created where
 * there is none; a plain rename where the file system can do neither. */
static int put_in_place(ch_temp_entry *e) {
  if (renameat2(AT_FDCWD, e->temp_path, AT_FDCWD, e->final_path, RENAME_EXCHANGE) == 0) {
    e->done = DONE_EXCHANGED;
    return 0;
  }
  if (errno == ENOENT) { /* no previous file */
    if (renameat2(AT_FDCWD, e->temp_path, AT_FDCWD, e->final_path, RENAME_NOREPLACE) == 0) {
      e->done = DONE_CREATED;
      return 0;
    }
    if (errno != EINVAL && errno != ENOSYS) return -1;
    if (rename(e->temp_path, e->final_path) != 0) return -1;
    e->done = DONE_CREATED;
    return 0;
  }
  if (errno != EINVAL && errno != ENOSYS) return -1;
  if (rename(e->temp_path, e->final_path) != 0) return -1;
  e->done = DONE_REPLACED;
  return 0;
}

ch_status ch_file_stage_commit(ch_error *err) {
  pthread_mutex_lock(&list_lock);
  staging = 0;
  ch_temp_entry *failed = NULL;
  int code = 0;
  for (ch_temp_entry *e = list_head; e; e = e->next) {
    if (!e->staged) continue;
    e->done = DONE_NOT;
    if (put_in_place(e) != 0) {
      failed = e;
      code = errno;
      break;
    }
  }
  int lost = 0;
  const char *lost_name = NULL;
  if (failed) /* put back what went into place, latest first */
    for (ch_temp_entry *e = failed->prev; e; e = e->prev) {
      if (!e->staged) continue;
      if (e->done == DONE_EXCHANGED) {
        if (renameat2(AT_FDCWD, e->temp_path, AT_FDCWD, e->final_path, RENAME_EXCHANGE) != 0) {
          e->done = DONE_KEPT; /* the previous file stays under the temporary's name, not removed */
          lost++;
          lost_name = e->final_path;
        }
      } else if (e->done == DONE_CREATED) {
        unlink(e->final_path);
      } else if (e->done == DONE_REPLACED) {
        lost++;
        lost_name = e->final_path;
      }
    }
  ch_status st = CH_OK;
  if (failed) {
    if (lost)
      st = ch_error_set(err, CH_ERR_IO, "%s: cannot move the finished file into place: %s (%d output%s already "
                        "replaced or left beside their targets, e.g. %s)",
                        failed->final_path, strerror(code), lost, lost > 1 ? "s were" : " was", lost_name);
    else
      st = ch_file_error(err, failed->final_path, "cannot move the finished file into place", code);
  }
  /* Every staged name left holds an old file (exchanged into it) or an
   * unused new one (or nothing: it was renamed away). */
  for (ch_temp_entry *e = list_head, *next; e; e = next) {
    next = e->next;
    if (!e->staged) continue;
    if (e->done != DONE_KEPT) unlink(e->temp_path);
    list_remove(e);
    free_entry(e);
  }
  pthread_mutex_unlock(&list_lock);
  return st;
}

void ch_file_stage_abort(void) {
  pthread_mutex_lock(&list_lock);
  staging = 0;
  for (ch_temp_entry *e = list_head, *next; e; e = next) {
    next = e->next;
    if (!e->staged) continue;
    unlink(e->temp_path);
    list_remove(e);
    free_entry(e);
  }
  pthread_mutex_unlock(&list_lock);
}

int ch_file_remove_temporaries(void) {
  pthread_mutex_lock(&list_lock);
  closed_down = 1;
  int n = 0;
  for (ch_temp_entry *e = list_head; e; e = e->next) n += unlink(e->temp_path) == 0;
  pthread_mutex_unlock(&list_lock);
  return n;
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
  char *buf = ch_alloc_large(n + 1, 1, 0); /* (a mesh of millions of faces: huge pages) */
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

char *ch_path_beside(const char *path, const char *rel) {
  const char *slash = strrchr(path, '/');
  size_t dir = rel[0] == '/' || !slash ? 0 : (size_t)(slash - path) + 1;
  char *out = malloc(dir + strlen(rel) + 1);
  if (!out) return NULL;
  memcpy(out, path, dir);
  strcpy(out + dir, rel);
  return out;
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
