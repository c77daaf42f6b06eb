/* A main for the libFuzzer targets without libFuzzer: runs
 * LLVMFuzzerTestOneInput once on every file named, and on every file in
 * every directory named (in name order), as libFuzzer does when given
 * files. So the regression inputs and the kept corpora run in every build
 * (gcc Release, ASan/UBSan) as ordinary tests, not only under clang.
 * usage: replay_TARGET FILE_OR_DIR... ; exit 0 when every input ran, 1
 * when one could not be read (a crash ends the process). */
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int run_file(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) return fprintf(stderr, "replay: %s: cannot open\n", path), 1;
  size_t cap = 1 << 16, n = 0;
  uint8_t *buf = malloc(cap);
  for (size_t got; buf && (got = fread(buf + n, 1, cap - n, f)) > 0;) {
    n += got;
    if (n == cap) {
      uint8_t *b = realloc(buf, cap *= 2);
      if (!b) free(buf);
      buf = b;
    }
  }
  int bad = ferror(f) || !buf;
  fclose(f);
  if (bad) {
    free(buf);
    return fprintf(stderr, "replay: %s: cannot read\n", path), 1;
  }
  /* (a copy of exactly n bytes, as libFuzzer gives: ASan sees overreads) */
  uint8_t *exact = malloc(n ? n : 1);
  if (!exact) return free(buf), 1;
  memcpy(exact, buf, n);
  free(buf);
  LLVMFuzzerTestOneInput(exact, n);
  free(exact);
  return 0;
}

static int cmp_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

int main(int argc, char **argv) {
  int failed = 0, ran = 0;
  for (int i = 1; i < argc; i++) {
    struct stat st;
    if (stat(argv[i], &st) != 0) {
      fprintf(stderr, "replay: %s: no such file or directory\n", argv[i]);
      failed = 1;
      continue;
    }
    if (!S_ISDIR(st.st_mode)) {
      failed |= run_file(argv[i]), ran++;
      continue;
    }
    DIR *d = opendir(argv[i]);
    if (!d) {
      fprintf(stderr, "replay: %s: cannot open\n", argv[i]);
      failed = 1;
      continue;
    }
    char **names = NULL;
    size_t n = 0, cap = 0;
    for (struct dirent *e; (e = readdir(d));) {
      if (e->d_name[0] == '.') continue;
      if (n == cap) {
        char **g = realloc(names, (cap = cap ? 2 * cap : 64) * sizeof *g);
        if (!g) return fprintf(stderr, "replay: out of memory\n"), 1;
        names = g;
      }
      size_t len = strlen(argv[i]) + strlen(e->d_name) + 2;
      if (!(names[n] = malloc(len))) return fprintf(stderr, "replay: out of memory\n"), 1;
      snprintf(names[n++], len, "%s/%s", argv[i], e->d_name);
    }
    closedir(d);
    qsort(names, n, sizeof *names, cmp_name);
    for (size_t k = 0; k < n; k++) {
      if (stat(names[k], &st) == 0 && S_ISREG(st.st_mode)) failed |= run_file(names[k]), ran++;
      free(names[k]);
    }
    free(names);
  }
  printf("replay: %d inputs\n", ran);
  return failed;
}
