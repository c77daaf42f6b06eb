/* ch_file: atomic outputs, staging (all outputs or none, a failure half
 * way put back), stale temporaries of killed runs, and the clean-up a
 * signal-handling thread does. Full disks and signals are tested end to
 * end in test_faults.sh. */
#define _GNU_SOURCE
#include <dirent.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "ch_file.h"
#include "ch_test.h"

static char dir[256];

static const char *at(const char *name) {
  static char paths[8][512];
  static int next = 0;
  char *p = paths[next++ % 8];
  snprintf(p, 512, "%s/%s", dir, name);
  return p;
}

static void put(const char *name, const char *text) {
  FILE *fp = fopen(at(name), "w");
  if (fp) {
    fputs(text, fp);
    fclose(fp);
  }
}

/* The file's text ("" if missing or longer than 63 bytes). */
static const char *text_of(const char *name) {
  static char buf[4][64];
  static int next = 0;
  char *b = buf[next++ % 4];
  b[0] = '\0';
  FILE *fp = fopen(at(name), "r");
  if (fp) {
    size_t n = fread(b, 1, 63, fp);
    b[n] = '\0';
    fclose(fp);
  }
  return b;
}

static int count_temporaries(void) {
  DIR *d = opendir(dir);
  int n = 0;
  for (struct dirent *de; d && (de = readdir(d));) n += strstr(de->d_name, ".tmp.") != NULL;
  if (d) closedir(d);
  return n;
}

static ch_status write_text(const char *name, const char *text, ch_error *err) {
  ch_atomic_file f;
  ch_status st = ch_atomic_open(&f, at(name), err);
  if (st) return st;
  fputs(text, f.fp);
  return ch_atomic_commit(&f, err);
}

static void test_atomic(void) {
  ch_error err = {0};
  put("a.txt", "old a");
  /* while writing: the target is as it was, a temporary named for it */
  ch_atomic_file f;
  REQUIRE(ch_atomic_open(&f, at("a.txt"), &err) == CH_OK);
  fputs("new a", f.fp);
  CHECK(strstr(f.temp_path, "a.txt.tmp.chisel-") != NULL);
  CHECK(strcmp(text_of("a.txt"), "old a") == 0);
  CHECK(count_temporaries() == 1);
  CHECK(ch_atomic_commit(&f, &err) == CH_OK);
  CHECK(strcmp(text_of("a.txt"), "new a") == 0);
  CHECK(count_temporaries() == 0);
  /* abort: nothing changes */
  REQUIRE(ch_atomic_open(&f, at("a.txt"), &err) == CH_OK);
  fputs("never", f.fp);
  ch_atomic_abort(&f);
  CHECK(strcmp(text_of("a.txt"), "new a") == 0);
  CHECK(count_temporaries() == 0);
  /* a directory that does not exist: an I/O error naming the path */
  CHECK(ch_atomic_open(&f, at("no/such/b.txt"), &err) == CH_ERR_IO);
  CHECK(strstr(err.message, "no/such/b.txt: cannot create file: No such file or directory") != NULL);
  CHECK(ch_status_exit_code(CH_ERR_IO) == 2);
}

/* A write the system fails part way (here over a file size limit: EFBIG,
 * as a full disk's ENOSPC) is the system's failure, exit status 1, not
 * the user's (2); nothing is left. In a child, so the limit stays there. */
static void test_failed_write(void) {
  put("big.txt", "old big");
  pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    signal(SIGXFSZ, SIG_IGN);
    struct rlimit lim = {16384, 16384};
    if (setrlimit(RLIMIT_FSIZE, &lim) != 0) _exit(10);
    ch_error err = {0};
    ch_atomic_file f;
    if (ch_atomic_open(&f, at("big.txt"), &err) != CH_OK) _exit(11);
    for (int i = 0; i < 10000; i++) fputs("0123456789", f.fp);
    ch_status st = ch_atomic_commit(&f, &err);
    if (st != CH_ERR_WRITE) _exit(12);
    if (!strstr(err.message, "big.txt: cannot write: File too large")) _exit(13);
    _exit(ch_status_exit_code(st) == 1 ? 0 : 14);
  }
  int status = 0;
  REQUIRE(waitpid(pid, &status, 0) == pid);
  CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0)) fprintf(stderr, "  child status %d\n", status);
  CHECK(strcmp(text_of("big.txt"), "old big") == 0);
  CHECK(count_temporaries() == 0);
}

static void test_staging(void) {
  ch_error err = {0};
  put("s1.txt", "old 1");
  put("s2.txt", "old 2");
  remove(at("s3.txt"));
  ch_file_stage_begin();
  CHECK(write_text("s1.txt", "new 1", &err) == CH_OK);
  CHECK(write_text("s2.txt", "new 2", &err) == CH_OK);
  CHECK(write_text("s3.txt", "new 3", &err) == CH_OK);
  /* committed files wait: the targets are as they were */
  CHECK(strcmp(text_of("s1.txt"), "old 1") == 0 && strcmp(text_of("s2.txt"), "old 2") == 0);
  CHECK(access(at("s3.txt"), F_OK) != 0);
  CHECK(count_temporaries() == 3);
  CHECK(ch_file_stage_commit(&err) == CH_OK);
  CHECK(strcmp(text_of("s1.txt"), "new 1") == 0 && strcmp(text_of("s2.txt"), "new 2") == 0);
  CHECK(strcmp(text_of("s3.txt"), "new 3") == 0);
  CHECK(count_temporaries() == 0); /* the old files, exchanged away, are gone too */

  /* a failure: the staged files are removed, the targets untouched */
  ch_file_stage_begin();
  CHECK(write_text("s1.txt", "newer 1", &err) == CH_OK);
  ch_file_stage_abort();
  CHECK(strcmp(text_of("s1.txt"), "new 1") == 0);
  CHECK(count_temporaries() == 0);

  /* a move that fails half way (the second file's temporary vanished):
   * the first is put back, the third never appears, nothing is left */
  put("s1.txt", "old 1");
  put("s2.txt", "old 2");
  remove(at("s3.txt"));
  ch_file_stage_begin();
  CHECK(write_text("s1.txt", "new 1", &err) == CH_OK);
  ch_atomic_file f;
  REQUIRE(ch_atomic_open(&f, at("s2.txt"), &err) == CH_OK);
  char temp[600];
  snprintf(temp, sizeof temp, "%s", f.temp_path);
  fputs("new 2", f.fp);
  CHECK(ch_atomic_commit(&f, &err) == CH_OK);
  CHECK(write_text("s3.txt", "new 3", &err) == CH_OK);
  CHECK(unlink(temp) == 0);
  memset(&err, 0, sizeof err);
  CHECK(ch_file_stage_commit(&err) == CH_ERR_IO);
  CHECK_MSG(strstr(err.message, "s2.txt: cannot move the finished file into place") != NULL, "%s", err.message);
  CHECK(strcmp(text_of("s1.txt"), "old 1") == 0 && strcmp(text_of("s2.txt"), "old 2") == 0);
  CHECK(access(at("s3.txt"), F_OK) != 0);
  CHECK(count_temporaries() == 0);
}

static int warnings;
static void count_warning(void *user, const char *message) {
  (void)user;
  (void)message;
  warnings++;
}

/* A temporary of a process that is gone is removed by the next open of
 * its target (with a warning); one of a live process, or of another
 * target, or not named exactly so, is left alone. */
static void test_stale(void) {
  pid_t child = fork();
  if (child == 0) _exit(0);
  REQUIRE(child > 0);
  waitpid(child, NULL, 0); /* now a PID no process has (for a while) */
  char dead[128], alive[128], other[128], odd[128];
  snprintf(dead, sizeof dead, "x.obj.tmp.chisel-%ld-Ab12Cd", (long)child);
  snprintf(alive, sizeof alive, "x.obj.tmp.chisel-%ld-Ab12Cd", (long)getppid());
  snprintf(other, sizeof other, "y.obj.tmp.chisel-%ld-Ab12Cd", (long)child);
  snprintf(odd, sizeof odd, "x.obj.tmp.chisel-%ld-Ab12Cd.bak", (long)child);
  put(dead, "partial");
  put(alive, "being written");
  put(other, "partial");
  put(odd, "a user's file");
  ch_error err = {.warn = count_warning};
  warnings = 0;
  CHECK(write_text("x.obj", "done", &err) == CH_OK);
  CHECK(access(at(dead), F_OK) != 0);
  CHECK(warnings == 1);
  CHECK(access(at(alive), F_OK) == 0 && access(at(other), F_OK) == 0 && access(at(odd), F_OK) == 0);
  remove(at(alive));
  remove(at(other));
  remove(at(odd));
}

/* What the signal-handling thread does: every temporary goes, and no new
 * one can start (last: it closes this process's outputs for good). */
static void test_remove_temporaries(void) {
  ch_error err = {0};
  ch_atomic_file f, g;
  REQUIRE(ch_atomic_open(&f, at("t1.txt"), &err) == CH_OK);
  fputs("x", f.fp);
  ch_file_stage_begin();
  CHECK(write_text("t2.txt", "y", &err) == CH_OK); /* staged */
  CHECK(count_temporaries() == 2);
  CHECK(ch_file_remove_temporaries() == 2);
  CHECK(count_temporaries() == 0);
  CHECK(ch_atomic_open(&g, at("t3.txt"), &err) == CH_ERR_IO);
  CHECK(strstr(err.message, "interrupted") != NULL);
  ch_atomic_abort(&f);
  CHECK(access(at("t1.txt"), F_OK) != 0 && access(at("t2.txt"), F_OK) != 0);
}

int main(void) {
  const char *tmp = getenv("TMPDIR");
  snprintf(dir, sizeof dir, "%s/test_file.XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
  if (!mkdtemp(dir)) {
    perror("mkdtemp");
    return 1;
  }
  RUN(test_atomic);
  RUN(test_failed_write);
  RUN(test_staging);
  RUN(test_stale);
  RUN(test_remove_temporaries);
  char cmd[600];
  snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
  if (!ch_test_failures && system(cmd) != 0) fprintf(stderr, "could not remove %s\n", dir);
  TEST_MAIN_END();
}
