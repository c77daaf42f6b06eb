/* Reading large meshes: ch_mesh_read and ch_mesh_validate (what `chisel
 * info` and a dense base mesh pay before anything else), median of 3, and
 * for OBJ the same file through OpenMesh's OBJ reader (the reference
 * ch_mesh_read_obj_openmesh keeps) as the baseline, in the same run.
 * bench/read.sh makes the files (chisel's own 2.1M-triangle outputs).
 * usage: bench_mesh_read FILE... */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "ch_file.h"
#include "ch_mesh.h"
#include "ch_mesh_obj_internal.h"

enum { RUNS = 3 };

/* Median seconds of reading path (through OpenMesh's OBJ reader when
 * openmesh is set); *faces gets the face count. */
static double time_read(const char *path, int openmesh, int *faces) {
  double t[RUNS];
  for (int r = 0; r < RUNS; r++) {
    ch_mesh m;
    ch_error err = {0};
    double t0 = bench_now();
    ch_status st;
    if (openmesh) {
      char *data = NULL;
      size_t size = 0;
      st = ch_file_read_all(path, (size_t)1 << 31, &data, &size, &err);
      if (st == CH_OK) st = ch_mesh_read_obj_openmesh(data, size, path, &m, &err);
      free(data);
    } else {
      st = ch_mesh_read(path, &m, &err);
    }
    t[r] = bench_now() - t0;
    if (st != CH_OK) {
      fprintf(stderr, "%s\n", err.message);
      exit(1);
    }
    *faces = m.num_faces;
    ch_mesh_free(&m);
  }
  return bench_median(t, RUNS);
}

static double time_validate(const char *path) {
  ch_mesh m;
  ch_error err = {0};
  if (ch_mesh_read(path, &m, &err) != CH_OK) {
    fprintf(stderr, "%s\n", err.message);
    exit(1);
  }
  double t[RUNS];
  for (int r = 0; r < RUNS; r++) {
    ch_mesh_report report;
    double t0 = bench_now();
    ch_mesh_validate(&m, path, &report, &err);
    t[r] = bench_now() - t0;
  }
  ch_mesh_free(&m);
  return bench_median(t, RUNS);
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: bench_mesh_read FILE...\n");
    return 2;
  }
  printf("ch_mesh_read and ch_mesh_validate, median of %d\n", RUNS);
  printf("| file | faces | read s | OpenMesh's OBJ reader s | ratio | validate s |\n|---|---|---|---|---|---|\n");
  for (int i = 1; i < argc; i++) {
    const char *path = argv[i], *dot = strrchr(path, '.');
    int faces = 0;
    double read = time_read(path, 0, &faces), validate = time_validate(path);
    if (dot && strcmp(dot, ".obj") == 0) {
      int ref_faces = 0;
      double ref = time_read(path, 1, &ref_faces);
      printf("| %s | %d | %.2f | %.2f | %.1fx | %.2f |\n", path, faces, read, ref, ref / read, validate);
    } else {
      printf("| %s | %d | %.2f | | | %.2f |\n", path, faces, read, validate);
    }
    fflush(stdout);
  }
  return 0;
}
