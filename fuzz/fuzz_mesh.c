/* libFuzzer target: a mesh reader (our scanner where we have one, then
 * OpenMesh's reader through our importer), then validation of whatever it
 * accepted. Built once per format: CHISEL_FUZZ_FORMAT is "obj", "ply",
 * "off", "stl", "glb" or "gltf" (glTF has a reader of our own,
 * mesh/ch_mesh_gltf_read.c, with no scanner before it).
 *
 * OBJ is read by our own reader (mesh/ch_mesh_obj_read.c); OpenMesh's
 * OBJReader reads every input too, and the two must agree: the same status
 * and message, warnings and mesh, value for value (abort otherwise). */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_mesh.h"
#include "ch_mesh_obj_internal.h"

#ifndef CHISEL_FUZZ_FORMAT
#define CHISEL_FUZZ_FORMAT "obj"
#endif

static void count_warning(void *user, const char *message) {
  (void)message;
  ++*(int *)user;
}

#define SAME_ARRAY(field, count, per)          \
  ((a->field == NULL) == (b->field == NULL) && \
   (!a->field || memcmp(a->field, b->field, (size_t)(count) * (per) * sizeof *a->field) == 0))

static int same_mesh(const ch_mesh *a, const ch_mesh *b) {
  return a->num_positions == b->num_positions && a->num_faces == b->num_faces && a->num_corners == b->num_corners &&
         a->num_uvs == b->num_uvs && a->num_normals == b->num_normals && SAME_ARRAY(positions, a->num_positions, 3) &&
         SAME_ARRAY(face_start, a->num_faces + 1, 1) && SAME_ARRAY(corner_position, a->num_corners, 1) &&
         SAME_ARRAY(uvs, a->num_uvs, 2) && SAME_ARRAY(corner_uv, a->num_corners, 1) &&
         SAME_ARRAY(normals, a->num_normals, 3) && SAME_ARRAY(corner_normal, a->num_corners, 1);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  ch_mesh mesh;
  int warnings = 0;
  ch_error err = {.warn = count_warning, .warn_user = &warnings};
  ch_status st = ch_mesh_read_memory(data, size, CHISEL_FUZZ_FORMAT, "fuzz." CHISEL_FUZZ_FORMAT, &mesh, &err);
  if (strcmp(CHISEL_FUZZ_FORMAT, "obj") == 0) {
    ch_mesh ref;
    int ref_warnings = 0;
    ch_error ref_err = {.warn = count_warning, .warn_user = &ref_warnings};
    ch_status ref_st = ch_mesh_read_obj_openmesh(data, size, "fuzz.obj", &ref, &ref_err);
    if (st != ref_st || strcmp(err.message, ref_err.message) != 0 || warnings != ref_warnings ||
        (st == CH_OK && !same_mesh(&mesh, &ref))) {
      fprintf(stderr, "OBJ readers differ: ours %d '%s' (%d warnings), OpenMesh's %d '%s' (%d warnings)\n", st,
              err.message, warnings, ref_st, ref_err.message, ref_warnings);
      abort();
    }
    ch_mesh_free(&ref);
  }
  if (st == CH_OK) {
    ch_mesh_report report;
    ch_mesh_validate(&mesh, "fuzz." CHISEL_FUZZ_FORMAT, &report, &err);
  }
  ch_mesh_free(&mesh);
  return 0;
}
