/* ch_scene: the study's scene file parsed with cJSON (ch_scene.h; the format
 * is documented in docs/cli.md, "chisel study"). */
#define _POSIX_C_SOURCE 200809L
#include "ch_scene.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_featmap.h"
#include "ch_file.h"
#include "ch_featshade.h"
#include "ch_gtex.h"
#include "ch_math.h"
#include "ch_relief.h"
#include "ch_truth.h"

static int check_keys(const cJSON *obj, const char *const *keys, const char *where, const char *file, ch_error *err) {
  for (const cJSON *it = obj->child; it; it = it->next) {
    int known = 0;
    for (int k = 0; keys[k]; k++) known |= !strcmp(it->string, keys[k]);
    if (!known) {
      ch_error_set(err, CH_ERR_INPUT, "%s: %s: unknown key '%s'", file, where, it->string);
      return 0;
    }
  }
  return 1;
}

static int get_vec3(const cJSON *obj, const char *key, double out[3], int required, const char *where,
                    const char *file, ch_error *err) {
  const cJSON *a = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!a) {
    if (required) ch_error_set(err, CH_ERR_INPUT, "%s: %s: missing \"%s\"", file, where, key);
    return !required;
  }
  if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 3) goto bad;
  for (int k = 0; k < 3; k++) {
    const cJSON *x = cJSON_GetArrayItem(a, k);
    if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble)) goto bad;
    out[k] = x->valuedouble;
  }
  return 1;
bad:
  ch_error_set(err, CH_ERR_INPUT, "%s: %s.%s: expected an array of 3 finite numbers", file, where, key);
  return 0;
}

/* A number in [lo, hi] (integer if integral); absent: keeps *out. */
static int get_number(const cJSON *obj, const char *key, double lo, double hi, int integral, double *out,
                      const char *where, const char *file, ch_error *err) {
  const cJSON *x = cJSON_GetObjectItemCaseSensitive(obj, key);
  if (!x) return 1;
  double v = cJSON_IsNumber(x) ? x->valuedouble : NAN;
  if (!(v >= lo && v <= hi) || (integral && v != floor(v))) {
    ch_error_set(err, CH_ERR_INPUT, "%s: %s.%s: expected %s in [%g, %g]", file, where, key,
                 integral ? "an integer" : "a number", lo, hi);
    return 0;
  }
  *out = v;
  return 1;
}

static int get_name(const cJSON *obj, char out[CH_SCENE_NAME_MAX], const char *where, const char *file, ch_error *err) {
  const cJSON *x = cJSON_GetObjectItemCaseSensitive(obj, "name");
  const char *s = cJSON_IsString(x) ? x->valuestring : NULL;
  int ok = s && s[0] && strlen(s) < CH_SCENE_NAME_MAX;
  for (const char *p = s; ok && *p; p++)
    ok = (*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') || *p == '-' || *p == '_';
  if (!ok) {
    ch_error_set(err, CH_ERR_INPUT, "%s: %s: \"name\" must be 1-%d letters, digits, '-' or '_'", file, where,
                 CH_SCENE_NAME_MAX - 1);
    return 0;
  }
  strcpy(out, s);
  return 1;
}

void ch_scene_free(ch_scene *s) {
  if (!s) return;
  free(s->curves_path);
  free(s->views);
  for (int i = 0; s->methods && i < s->num_methods; i++) free(s->methods[i].path);
  free(s->methods);
  memset(s, 0, sizeof *s);
}

/* A method's "shader" and its parameters: exact-normals; grooves with
 * "resolution" G (and "paper"); relief, pom with "resolution" R and
 * "steps" K (default 32). */
static int parse_shader(const cJSON *m, ch_scene_method *mt, const char *where, const char *file, ch_error *err) {
  const cJSON *shader = cJSON_GetObjectItemCaseSensitive(m, "shader");
  const cJSON *res = cJSON_GetObjectItemCaseSensitive(m, "resolution"), *steps = cJSON_GetObjectItemCaseSensitive(m, "steps");
  const cJSON *paper = cJSON_GetObjectItemCaseSensitive(m, "paper");
  const char *name = cJSON_IsString(shader) ? shader->valuestring : "";
  int grooves = !strcmp(name, "grooves"), relief = !strcmp(name, "relief"), pom = !strcmp(name, "pom");
  int feat = ch_featshade_method_parse(name);
  mt->featshade = feat;
  if (shader && !grooves && !relief && !pom && feat < 0 && strcmp(name, "exact-normals")) {
    ch_error_set(err, CH_ERR_INPUT,
                 "%s: %s.shader: unknown shader (known: \"exact-normals\", \"grooves\", \"relief\", \"pom\", "
                 "\"featnorm\", \"featnorm-linear\", \"normal-bilinear\", \"msdf\")",
                 file, where);
    return 0;
  }
  const char *extra = !(grooves || relief || pom || feat >= 0) && res ? "resolution"
                      : !(relief || pom) && steps                     ? "steps"
                      : !grooves && paper                                                    ? "paper"
                                                                                             : NULL;
  if (extra) {
    ch_error_set(err, CH_ERR_INPUT, "%s: %s.%s: only for %s", file, where, extra,
                 !strcmp(extra, "steps") ? "\"shader\": \"relief\" or \"pom\""
                 : !strcmp(extra, "paper") ? "\"shader\": \"grooves\""
                                            : "\"shader\": \"grooves\", \"relief\" or \"pom\"");
    return 0;
  }
  mt->exact_normals = shader && !strcmp(name, "exact-normals");
  if (feat >= 0) {
    double r = 0;
    if (!res) {
      ch_error_set(err, CH_ERR_INPUT, "%s: %s.resolution: missing (shader \"%s\" needs the maps' resolution R)", file,
                   where, name);
      return 0;
    }
    if (!get_number(m, "resolution", CH_FEATMAP_MIN_RES, CH_FEATMAP_MAX_RES, 1, &r, where, file, err)) return 0;
    mt->resolution = (int)r;
    return 1;
  }
  if (!(grooves || relief || pom)) return 1;
  if (!res) {
    ch_error_set(err, CH_ERR_INPUT, "%s: %s.resolution: missing (shader \"%s\" needs the %s)", file, where, name,
                 grooves ? "grid resolution G" : "height texture's resolution R");
    return 0;
  }
  double r = 0, k = 32;
  if (!get_number(m, "resolution", grooves ? CH_GTEX_MIN_RES : CH_RELIEF_MIN_RES,
                  grooves ? CH_GTEX_MAX_RES : CH_RELIEF_MAX_RES, 1, &r, where, file, err) ||
      !get_number(m, "steps", CH_RELIEF_MIN_STEPS, CH_RELIEF_MAX_STEPS, 1, &k, where, file, err))
    return 0;
  if (paper && !cJSON_IsBool(paper)) {
    ch_error_set(err, CH_ERR_INPUT, "%s: %s.paper: expected true or false", file, where);
    return 0;
  }
  mt->textured = 1;
  mt->tex.kind = grooves ? CH_TEXRAY_GROOVES : relief ? CH_TEXRAY_RELIEF : CH_TEXRAY_POM;
  mt->tex.resolution = (int)r;
  mt->tex.steps = (int)k;
  mt->tex.paper = cJSON_IsTrue(paper);
  return 1;
}

ch_status ch_scene_parse(const char *file, const char *text, ch_scene *s, ch_error *err) {
  memset(s, 0, sizeof *s);
  s->dci_resolution = 1024;
  s->truth_grid = 512;
  cJSON *root = cJSON_Parse(text);
  if (!root) {
    const char *at = cJSON_GetErrorPtr();
    long line = 1;
    for (const char *p = text; at && p < at && *p; p++) line += *p == '\n';
    return ch_error_set(err, CH_ERR_INPUT, "%s: line %ld: not valid JSON", file, line);
  }
  static const char *const top_keys[] = {"curves", "dci_resolution", "truth_grid", "light", "views", "methods", NULL};
  static const char *const light_keys[] = {"direction", "ambient", "albedo", "specular", "shininess", NULL};
  static const char *const view_keys[] = {"name",   "eye",         "target",       "up",    "fov", "width",
                                          "height", "supersample", "ortho_height", "orbit", NULL};
  static const char *const method_keys[] = {"name", "mesh", "shader", "family", "resolution", "steps", "paper", NULL};
  char where[96];
  const cJSON *curves = cJSON_GetObjectItemCaseSensitive(root, "curves");
  const cJSON *views = cJSON_GetObjectItemCaseSensitive(root, "views");
  const cJSON *methods = cJSON_GetObjectItemCaseSensitive(root, "methods");
  const cJSON *light = cJSON_GetObjectItemCaseSensitive(root, "light");
  double dres = s->dci_resolution, grid = s->truth_grid;
  if (!cJSON_IsObject(root)) {
    ch_error_set(err, CH_ERR_INPUT, "%s: the scene must be a JSON object", file);
    goto fail;
  }
  if (!check_keys(root, top_keys, "scene", file, err)) goto fail;
  if (!cJSON_IsString(curves) || !curves->valuestring[0]) {
    ch_error_set(err, CH_ERR_INPUT, "%s: \"curves\": expected the path of an SVG file", file);
    goto fail;
  }
  if (!get_number(root, "dci_resolution", 16, 16384, 1, &dres, "scene", file, err) ||
      !get_number(root, "truth_grid", 16, 16384, 1, &grid, "scene", file, err))
    goto fail;
  if ((int)grid % CH_TRUTH_TILE) {
    ch_error_set(err, CH_ERR_INPUT, "%s: scene.truth_grid: %d is not a multiple of %d", file, (int)grid, CH_TRUTH_TILE);
    goto fail;
  }
  s->dci_resolution = (int)dres;
  s->truth_grid = (int)grid;
  if (light) {
    if (!cJSON_IsObject(light)) {
      ch_error_set(err, CH_ERR_INPUT, "%s: \"light\": expected an object", file);
      goto fail;
    }
    if (!check_keys(light, light_keys, "light", file, err) ||
        !get_vec3(light, "direction", s->light.direction, 0, "light", file, err) ||
        !get_number(light, "ambient", 0, 1, 0, &s->light.ambient, "light", file, err) ||
        !get_number(light, "albedo", 0, 1, 0, &s->light.albedo, "light", file, err) ||
        !get_number(light, "specular", 0, 10, 0, &s->light.specular, "light", file, err) ||
        !get_number(light, "shininess", 0, 10000, 0, &s->light.shininess, "light", file, err))
      goto fail;
  }
  if (!cJSON_IsArray(views) || cJSON_GetArraySize(views) < 1) {
    ch_error_set(err, CH_ERR_INPUT, "%s: \"views\": expected an array of at least one view", file);
    goto fail;
  }
  if (methods && !cJSON_IsArray(methods)) {
    ch_error_set(err, CH_ERR_INPUT, "%s: \"methods\": expected an array", file);
    goto fail;
  }
  if (!(s->curves_path = ch_path_beside(file, curves->valuestring))) goto nomem;
  /* Views after orbits are expanded (an orbit's count is checked below). */
  s->num_views = 0;
  for (int i = 0; i < cJSON_GetArraySize(views); i++) {
    const cJSON *o = cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(views, i), "orbit");
    s->num_views += cJSON_IsNumber(o) && o->valuedouble >= 1 && o->valuedouble <= 64 ? (int)o->valuedouble : 1;
  }
  s->num_methods = methods ? cJSON_GetArraySize(methods) : 0;
  if (s->num_views > CH_SCENE_MAX_VIEWS || s->num_methods > CH_SCENE_MAX_METHODS) {
    ch_error_set(err, CH_ERR_INPUT, "%s: at most 256 views and 32 methods (got %d and %d)", file, s->num_views,
                 s->num_methods);
    s->num_views = s->num_methods = 0;
    goto fail;
  }
  s->views = calloc((size_t)s->num_views, sizeof *s->views);
  s->methods = calloc((size_t)(s->num_methods ? s->num_methods : 1), sizeof *s->methods);
  if (!s->views || !s->methods) goto nomem;
  for (int i = 0, out = 0; i < cJSON_GetArraySize(views); i++) {
    const cJSON *v = cJSON_GetArrayItem(views, i);
    snprintf(where, sizeof where, "views[%d]", i);
    if (!cJSON_IsObject(v)) {
      ch_error_set(err, CH_ERR_INPUT, "%s: %s: expected an object", file, where);
      goto fail;
    }
    ch_scene_view *vw = &s->views[out];
    ch_render_camera *c = &vw->camera;
    double width = 320, height = 240, ss = 2, fov = 40, ortho = 0, orbit = 1;
    c->up[2] = 1.0;
    if (!check_keys(v, view_keys, where, file, err) || !get_name(v, vw->name, where, file, err) ||
        !get_vec3(v, "eye", c->eye, 1, where, file, err) || !get_vec3(v, "target", c->target, 1, where, file, err) ||
        !get_vec3(v, "up", c->up, 0, where, file, err) || !get_number(v, "fov", 0.1, 170, 0, &fov, where, file, err) ||
        !get_number(v, "ortho_height", 0, 1e6, 0, &ortho, where, file, err) ||
        !get_number(v, "width", 1, 8192, 1, &width, where, file, err) ||
        !get_number(v, "height", 1, 8192, 1, &height, where, file, err) ||
        !get_number(v, "supersample", 1, 16, 1, &ss, where, file, err) ||
        !get_number(v, "orbit", 1, 64, 1, &orbit, where, file, err))
      goto fail;
    if (orbit > 1 && strlen(vw->name) + 3 >= CH_SCENE_NAME_MAX) {
      ch_error_set(err, CH_ERR_INPUT, "%s: %s: the name '%s' is too long for an orbit's views", file, where, vw->name);
      goto fail;
    }
    c->fov_deg = fov;
    c->ortho_height = ortho;
    c->width = (int)width;
    c->height = (int)height;
    c->supersample = (int)ss;
    const ch_scene_view first = *vw;
    for (int k = 0; k < (int)orbit; k++, out++) {
      ch_scene_view *ov = &s->views[out];
      *ov = first;
      if (orbit > 1) {
        /* The eye turned by 360 k / n degrees about the vertical through the target. */
        double a = 2.0 * CH_PI * k / orbit, dx = first.camera.eye[0] - first.camera.target[0];
        double dy = first.camera.eye[1] - first.camera.target[1];
        ov->camera.eye[0] = first.camera.target[0] + dx * cos(a) - dy * sin(a);
        ov->camera.eye[1] = first.camera.target[1] + dx * sin(a) + dy * cos(a);
        char named[CH_SCENE_NAME_MAX + 16]; /* fits: the length was checked above */
        snprintf(named, sizeof named, "%s_%d", first.name, k);
        memcpy(ov->name, named, CH_SCENE_NAME_MAX - 1);
        ov->name[CH_SCENE_NAME_MAX - 1] = '\0';
      }
      for (int j = 0; j < out; j++)
        if (!strcmp(s->views[j].name, ov->name)) {
          ch_error_set(err, CH_ERR_INPUT, "%s: %s: the name '%s' is used twice", file, where, ov->name);
          goto fail;
        }
      /* The camera's own checks (view direction, up), with the view's name. */
      double o[3], d[3];
      ch_error cerr = {0};
      if (ch_render_camera_ray(&ov->camera, 0, 0, o, d, &cerr)) {
        ch_error_set(err, CH_ERR_INPUT, "%s: %s ('%s'): %s", file, where, ov->name, cerr.message);
        goto fail;
      }
    }
  }
  for (int i = 0; i < s->num_methods; i++) {
    const cJSON *m = cJSON_GetArrayItem(methods, i);
    snprintf(where, sizeof where, "methods[%d]", i);
    if (!cJSON_IsObject(m)) {
      ch_error_set(err, CH_ERR_INPUT, "%s: %s: expected an object", file, where);
      goto fail;
    }
    ch_scene_method *mt = &s->methods[i];
    const cJSON *mesh = cJSON_GetObjectItemCaseSensitive(m, "mesh");
    if (!check_keys(m, method_keys, where, file, err) || !get_name(m, mt->name, where, file, err)) goto fail;
    if (!strcmp(mt->name, "truth")) {
      ch_error_set(err, CH_ERR_INPUT, "%s: %s: the name 'truth' is reserved", file, where);
      goto fail;
    }
    for (int j = 0; j < i; j++)
      if (!strcmp(s->methods[j].name, mt->name)) {
        ch_error_set(err, CH_ERR_INPUT, "%s: %s: the name '%s' is used twice", file, where, mt->name);
        goto fail;
      }
    if (!cJSON_IsString(mesh) || !mesh->valuestring[0]) {
      ch_error_set(err, CH_ERR_INPUT, "%s: %s.mesh: expected the path of a mesh file", file, where);
      goto fail;
    }
    const cJSON *family = cJSON_GetObjectItemCaseSensitive(m, "family");
    strcpy(mt->family, mt->name);
    if (family) {
      if (!cJSON_IsString(family) || !family->valuestring[0] || strlen(family->valuestring) >= CH_SCENE_NAME_MAX ||
          strpbrk(family->valuestring, "<>&\"'")) {
        ch_error_set(err, CH_ERR_INPUT, "%s: %s.family: expected a short name without <>&\"'", file, where);
        goto fail;
      }
      strcpy(mt->family, family->valuestring);
    }
    if (!parse_shader(m, mt, where, file, err)) goto fail;
    if (!(mt->path = ch_path_beside(file, mesh->valuestring))) goto nomem;
  }
  cJSON_Delete(root);
  return CH_OK;
nomem:
  ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", file);
fail:
  cJSON_Delete(root);
  ch_scene_free(s);
  return err->status;
}
