/* ch_study and ch_report as a library caller uses them: the bundled
 * box_groove scene (its method's mesh is the truth's own surface) built,
 * run into a folder, with its progress; every file the study names
 * written, the rows zero mismatch, summary.csv read back against the rows,
 * and a second run in the same process giving the same index.html bytes
 * (nothing carried between reports). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ch_file.h"
#include "ch_scene.h"
#include "ch_study.h"
#include "ch_test.h"

typedef struct seen {
  int calls;
  double last;
  int monotone;
} seen;

static void on_progress(void *user, const char *stage, double fraction) {
  seen *s = user;
  s->monotone &= fraction >= s->last && stage[0] != '\0';
  s->last = fraction;
  s->calls++;
}

static char *slurp(const char *path, size_t *size) {
  char *text = NULL;
  ch_error err = {0};
  if (ch_file_read_all(path, 1 << 24, &text, size, &err)) return NULL;
  return text;
}

static void test_run(void) {
  const char *scene_path = CHISEL_TEST_DATA "/study/box_groove.json";
  size_t size;
  char *text = slurp(scene_path, &size);
  REQUIRE(text);
  ch_scene s;
  ch_error err = {0};
  REQUIRE(ch_scene_parse(scene_path, text, &s, &err) == CH_OK);
  ch_study *study = NULL;
  REQUIRE(ch_study_create(&s, scene_path, NULL, &study, &err) == CH_OK);
  CHECK(ch_study_texture_bytes(study, 0) == 0);
  CHECK(ch_study_scene_size(study) > 1.41 && ch_study_scene_size(study) < 1.42);

  setenv("SOURCE_DATE_EPOCH", "86400", 1);
  const char *tmp = getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
  char dirs[2][512], path[1024];
  char *index[2] = {NULL, NULL};
  size_t index_size[2] = {0, 0};
  const ch_report_info info = {"chisel study box_groove.json", "box_groove.json", text};
  for (int run = 0; run < 2; run++) {
    snprintf(dirs[run], sizeof dirs[run], "%s/test_study_lib_%d_%d", tmp, (int)getpid(), run);
    REQUIRE(mkdir(dirs[run], 0777) == 0);
    seen sn = {0, -1.0, 1};
    const ch_progress progress = {on_progress, &sn};
    ch_study_row *rows = NULL;
    int nrows = 0, nfiles = 0;
    ch_status st = ch_study_run(study, dirs[run], &info, &progress, &rows, &nrows, &nfiles, &err);
    CHECK_MSG(st == CH_OK, "%s", err.message);
    REQUIRE(rows);
    /* Per view: the truth's EXR and 2 PNGs, the method's EXR and 4 PNGs, the
     * montage; then summary.csv, summary.json, index.html. */
    CHECK(nrows == 3 && nfiles == 3 * 9 + 3);
    CHECK(sn.calls == 6 && sn.monotone && sn.last == 1.0);
    for (int i = 0; i < nrows; i++) {
      CHECK(rows[i].view == i && rows[i].method == 0 && rows[i].triangles > 0 && rows[i].rays > 0);
      CHECK(rows[i].m.class_mismatch == 0 && rows[i].m.id_mismatch == 0 && rows[i].m.normal_p95_deg < 1e-3);
    }
    static const char *const names[] = {"oblique.truth.exr", "across.exact.depth.png", "ortho.montage.png",
                                        "summary.json"};
    for (int k = 0; k < 4; k++) {
      struct stat sb;
      snprintf(path, sizeof path, "%s/%s", dirs[run], names[k]);
      CHECK_MSG(stat(path, &sb) == 0 && sb.st_size > 0, "%s", path);
    }
    /* summary.csv: the header, then a line per row with its view, method and
     * class mismatch as the row has them. */
    snprintf(path, sizeof path, "%s/summary.csv", dirs[run]);
    size_t n;
    char *csv = slurp(path, &n);
    REQUIRE(csv);
    char *line = strtok(csv, "\n");
    CHECK(line && !strncmp(line, "view,method,family,triangles,class_mismatch_pct,", 48));
    for (int i = 0; i < nrows; i++) {
      line = strtok(NULL, "\n");
      char want[256];
      snprintf(want, sizeof want, "%s,exact,exact,%ld,%.6f,", s.views[i].name, rows[i].triangles,
               rows[i].m.class_mismatch);
      CHECK_MSG(line && !strncmp(line, want, strlen(want)), "%s against %s", line ? line : "(none)", want);
    }
    CHECK(strtok(NULL, "\n") == NULL);
    free(csv);
    snprintf(path, sizeof path, "%s/index.html", dirs[run]);
    index[run] = slurp(path, &index_size[run]);
    CHECK(index[run] && strstr(index[run], "Command: <code>chisel study box_groove.json</code>") &&
          strstr(index[run], "1970-01-02 00:00:00 UTC") && strstr(index[run], "id=\"cb1\""));
    free(rows);
    /* Clean up the folder. */
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dirs[run]);
    CHECK(system(cmd) == 0);
  }
  CHECK(index[0] && index[1] && index_size[0] == index_size[1] && !memcmp(index[0], index[1], index_size[0]));
  free(index[0]);
  free(index[1]);
  /* A folder that is not there: an error naming the file, no rows. */
  ch_study_row *rows = (ch_study_row *)&err;
  int nrows = -1, nfiles = -1;
  CHECK(ch_study_run(study, "/nonexistent/folder", &info, NULL, &rows, &nrows, &nfiles, &err) != CH_OK);
  CHECK(rows == NULL && nrows == 0 && nfiles == 0 && strstr(err.message, "/nonexistent/folder/"));
  ch_study_destroy(study);
  ch_scene_free(&s);
  free(text);
}

/* A method's mesh that is missing: create fails naming it, nothing built. */
static void test_missing_mesh(void) {
  const char *text = "{\"curves\": \"box_groove.svg\", \"dci_resolution\": 64, \"truth_grid\": 64, \"views\": "
                     "[{\"name\": \"v\", \"eye\": [0, -1, 1], \"target\": [0.5, 0.5, 0]}], \"methods\": "
                     "[{\"name\": \"m\", \"mesh\": \"no_such_mesh.obj\"}]}";
  ch_scene s;
  ch_error err = {0};
  REQUIRE(ch_scene_parse(CHISEL_TEST_DATA "/study/x.json", text, &s, &err) == CH_OK);
  ch_study *study = (ch_study *)&err;
  CHECK(ch_study_create(&s, "x.json", NULL, &study, &err) != CH_OK);
  CHECK_MSG(study == NULL && strstr(err.message, "no_such_mesh.obj"), "%s", err.message);
  ch_scene_free(&s);
}

int main(void) {
  RUN(test_run);
  RUN(test_missing_mesh);
  TEST_MAIN_END();
}
