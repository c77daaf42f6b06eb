/* Tests for src/core image I/O: ch_exr (OpenEXRCore) and ch_png (libpng).
 *
 * Usage:
 *   test_image                              run every test
 *   test_image --write-exr-samples DIR      write sample EXRs + DIR/expected.txt
 *                                           (checked by tests/tools/exr_read.py)
 *   test_image --compare-exr A B            read both, compare channels by name
 *                                           exactly (e.g. against exrmaketiled)
 *
 * Hand-built files (tiled, uint channels, data windows not at 0, deep,
 * absurd sizes) are assembled byte by byte here from the OpenEXR file layout
 * document, so the reader is tested on files OpenEXRCore did not write. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ch_error.h"
#include "ch_exr.h"
#include "ch_file.h"
#include "ch_image.h"
#include "ch_png.h"
#include "ch_test.h"

static char tmpdir[512];

static const char *tmp_path(const char *name) {
  static char buf[8][600];
  static int slot = 0;
  slot = (slot + 1) % 8;
  snprintf(buf[slot], sizeof buf[slot], "%s/%s", tmpdir, name);
  return buf[slot];
}

static int file_exists(const char *path) {
  struct stat sb;
  return stat(path, &sb) == 0;
}

static int write_bytes(const char *path, const void *data, size_t n) {
  FILE *fp = fopen(path, "wb");
  if (!fp) return 0;
  int ok = fwrite(data, 1, n, fp) == n;
  return fclose(fp) == 0 && ok;
}

static unsigned char *slurp(const char *path, size_t *n) {
  char *data = NULL;
  ch_error err = {0};
  if (ch_file_read_all(path, (size_t)1 << 30, &data, n, &err) != CH_OK) return NULL;
  return (unsigned char *)data;
}

/* The message rules: one printable line, and it names the file. */
static int message_ok(const ch_error *err, const char *name) {
  for (const char *p = err->message; *p; p++)
    if ((unsigned char)*p < 32 || (unsigned char)*p >= 127) return 0;
  return err->message[0] != '\0' && strstr(err->message, name) != NULL;
}

static uint32_t rng_state = 12345u;
static uint32_t rng(void) {
  rng_state = rng_state * 1664525u + 1013904223u;
  return rng_state >> 8;
}
static float rnd_float(void) { return (float)((double)rng() / (1 << 24) * 2.0 - 1.0); }

static uint32_t float_bits(float f) {
  uint32_t b;
  memcpy(&b, &f, sizeof b);
  return b;
}
static float bits_float(uint32_t b) {
  float f;
  memcpy(&f, &b, sizeof f);
  return f;
}

/* Fills an image with a mix of smooth values, random values and special
 * floats (signed zero, subnormals, huge, infinities, a NaN payload). */
static void fill_image(ch_image *img, int with_specials) {
  for (int c = 0; c < img->num_channels; c++) {
    float *p = ch_image_plane(img, c);
    for (int y = 0; y < img->height; y++)
      for (int x = 0; x < img->width; x++) {
        size_t i = (size_t)y * img->width + x;
        p[i] = (x + y) % 3 ? 0.01f * (float)(x - 2 * y + 7 * c) : rnd_float() * 100.0f;
      }
    if (with_specials && img->width * img->height >= 8) {
      p[0] = -0.0f;
      p[1] = bits_float(0x00000001u); /* smallest subnormal */
      p[2] = 3.4e38f;
      p[3] = bits_float(0x7f800000u);  /* +inf */
      p[4] = bits_float(0xff800000u);  /* -inf */
      p[5] = bits_float(0x7fc01234u);  /* NaN with a payload */
      p[6] = 1e-40f;
      p[7] = -123456.789f;
    }
  }
}

static int planes_bit_equal(const ch_image *a, int ca, const ch_image *b, int cb) {
  size_t n = (size_t)a->width * a->height;
  return memcmp(ch_image_plane(a, ca), ch_image_plane(b, cb), n * sizeof(float)) == 0;
}

static const char *comp_name(ch_exr_compression c) {
  return c == CH_EXR_NONE ? "none" : c == CH_EXR_PIZ ? "piz" : "zip";
}

/* ------------------------------------------------------------------------ */

static void test_float_roundtrip(void) {
  static const int sizes[][2] = {{1, 1}, {4, 4}, {37, 23}, {3, 40}, {129, 17}};
  static const ch_exr_compression comps[] = {CH_EXR_NONE, CH_EXR_ZIP, CH_EXR_PIZ};
  const char *names[3] = {"R", "G", "B"};
  for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
    for (size_t k = 0; k < 3; k++) {
      ch_image img, back;
      ch_error err = {0};
      REQUIRE(ch_image_init(&img, sizes[s][0], sizes[s][1], 3, names, &err) == CH_OK);
      fill_image(&img, 1);
      ch_exr_write_desc d = {0};
      d.compression = comps[k];
      char name[64];
      snprintf(name, sizeof name, "rt_%dx%d_%s.exr", sizes[s][0], sizes[s][1],
               comp_name(comps[k]));
      const char *path = tmp_path(name);
      ch_status st = ch_exr_write(path, &img, &d, &err);
      CHECK_MSG(st == CH_OK, "%s", err.message);
      st = ch_exr_read(path, &back, &err);
      CHECK_MSG(st == CH_OK, "%s", err.message);
      if (st == CH_OK) {
        CHECK(back.width == img.width && back.height == img.height && back.num_channels == 3);
        for (int c = 0; c < 3; c++) {
          int bc = ch_image_find(&back, names[c]);
          CHECK_MSG(bc >= 0 && planes_bit_equal(&img, c, &back, bc), "%s channel %s", name,
                    names[c]);
        }
      }
      ch_image_free(&back);
      ch_image_free(&img);
    }
  }
}

static int half_close(float v, float r) {
  if (isnan(v)) return isnan(r);
  if (isinf(v)) return isinf(r) && (v > 0) == (r > 0);
  double tol = fabs((double)v) * (1.0 / 2048.0);
  if (tol < 1.0 / 33554432.0) tol = 1.0 / 33554432.0; /* subnormal half ulp 2^-25 */
  return fabs((double)v - (double)r) <= tol;
}

static void test_mixed_half_float(void) {
  static const ch_exr_compression comps[] = {CH_EXR_NONE, CH_EXR_ZIP, CH_EXR_PIZ};
  const char *names[4] = {"height", "mask", "A", "normal.x"};
  ch_exr_type types[4] = {CH_EXR_FLOAT, CH_EXR_HALF, CH_EXR_FLOAT, CH_EXR_HALF};
  for (int k = 0; k < 3; k++) {
    ch_image img, back;
    ch_error err = {0};
    REQUIRE(ch_image_init(&img, 37, 23, 4, names, &err) == CH_OK);
    fill_image(&img, 0);
    float *m = ch_image_plane(&img, 1);
    m[0] = 0.5f;       /* exact in half */
    m[1] = 1.0f / 3;   /* rounded */
    m[2] = 65504.0f;   /* largest half */
    m[3] = 6.0e-8f;    /* half subnormal */
    m[4] = -2.0f;
    ch_exr_write_desc d = {0};
    d.channel_types = types;
    d.compression = comps[k];
    char name[64];
    snprintf(name, sizeof name, "mixed_%s.exr", comp_name(comps[k]));
    const char *path = tmp_path(name);
    ch_status st = ch_exr_write(path, &img, &d, &err);
    CHECK_MSG(st == CH_OK, "%s", err.message);
    st = ch_exr_read(path, &back, &err);
    CHECK_MSG(st == CH_OK, "%s", err.message);
    if (st == CH_OK) {
      REQUIRE(back.num_channels == 4);
      for (int c = 0; c < 4; c++) {
        int bc = ch_image_find(&back, names[c]);
        REQUIRE(bc >= 0);
        if (types[c] == CH_EXR_FLOAT) {
          CHECK_MSG(planes_bit_equal(&img, c, &back, bc), "%s %s", name, names[c]);
        } else {
          const float *a = ch_image_plane(&img, c), *b = ch_image_plane(&back, bc);
          int bad = 0;
          for (int i = 0; i < img.width * img.height; i++)
            if (!half_close(a[i], b[i])) {
              if (bad++ < 3)
                fprintf(stderr, "  %s %s[%d]: wrote %.9g read %.9g\n", name, names[c], i, a[i],
                        b[i]);
            }
          CHECK_MSG(bad == 0, "%s %s: %d values off", name, names[c], bad);
        }
      }
      const float *b = ch_image_plane(&back, ch_image_find(&back, "mask"));
      CHECK(b[0] == 0.5f && b[2] == 65504.0f && b[4] == -2.0f);
    }
    ch_image_free(&back);
    ch_image_free(&img);
  }
  /* All-half files, 3 and 4 channels: the shapes with specialised
   * unpackers in OpenEXRCore. */
  for (int nc = 1; nc <= 5; nc++) {
    const char *hn[5] = {"R", "G", "B", "A", "Z"};
    ch_image img, back;
    ch_error err = {0};
    REQUIRE(ch_image_init(&img, 9, 5, nc, hn, &err) == CH_OK);
    for (int c = 0; c < nc; c++)
      for (int i = 0; i < 45; i++) ch_image_plane(&img, c)[i] = (float)(c * 100 + i);
    ch_exr_write_desc d = {0};
    d.type = CH_EXR_HALF;
    for (int k = 0; k < 3; k++) {
      d.compression = comps[k];
      const char *path = tmp_path("allhalf.exr");
      CHECK_MSG(ch_exr_write(path, &img, &d, &err) == CH_OK, "%s", err.message);
      CHECK_MSG(ch_exr_read(path, &back, &err) == CH_OK, "%s", err.message);
      for (int c = 0; c < nc && back.pixels; c++) {
        int bc = ch_image_find(&back, hn[c]);
        CHECK_MSG(bc >= 0 && planes_bit_equal(&img, c, &back, bc), "all-half %d ch, %s, %s", nc,
                  comp_name(comps[k]), hn[c]);
      }
      ch_image_free(&back);
    }
    ch_image_free(&img);
  }
}

static void test_names_and_order(void) {
  /* Written in an order EXR will not keep (it sorts channel names). */
  const char *names[6] = {"z", "B", "alpha", "A", "height", "a.very.long.channel.name.of.40.chars"};
  ch_image img, back;
  ch_error err = {0};
  REQUIRE(ch_image_init(&img, 6, 5, 6, names, &err) == CH_OK);
  for (int c = 0; c < 6; c++)
    for (int i = 0; i < 30; i++) ch_image_plane(&img, c)[i] = (float)(1000 * c + i);
  const char *path = tmp_path("names.exr");
  CHECK_MSG(ch_exr_write(path, &img, NULL, &err) == CH_OK, "%s", err.message);
  REQUIRE(ch_exr_read(path, &back, &err) == CH_OK);
  REQUIRE(back.num_channels == 6);
  /* the file's order is sorted */
  for (int c = 1; c < 6; c++) CHECK(strcmp(back.names[c - 1], back.names[c]) < 0);
  for (int c = 0; c < 6; c++) {
    int bc = ch_image_find(&back, names[c]);
    CHECK_MSG(bc >= 0, "channel %s missing", names[c]);
    if (bc >= 0) CHECK(planes_bit_equal(&img, c, &back, bc));
  }
  ch_image_free(&back);

  /* Duplicate names cannot be written, and nothing is left behind. */
  snprintf(img.names[1], CH_IMAGE_NAME_MAX, "z");
  const char *dup = tmp_path("dup.exr");
  ch_status st = ch_exr_write(dup, &img, NULL, &err);
  CHECK(st == CH_ERR_INPUT && message_ok(&err, "dup.exr"));
  CHECK(!file_exists(dup));
  ch_image_free(&img);
}

static int count_leftovers(const char *prefix) {
  DIR *d = opendir(tmpdir);
  int n = 0;
  if (!d) return -1;
  struct dirent *e;
  while ((e = readdir(d)) != NULL)
    if (strncmp(e->d_name, prefix, strlen(prefix)) == 0) n++;
  closedir(d);
  return n;
}

static void test_attributes(void) {
  ch_image img;
  ch_error err = {0};
  REQUIRE(ch_image_init(&img, 2, 2, 1, NULL, &err) == CH_OK);
  ch_exr_attribute attrs[3] = {{"chisel:command", "chisel bake --in a.obj --out b.exr"},
                               {"chisel:version", "0.1.0"},
                               {"chisel:empty", ""}};
  ch_exr_write_desc d = {0};
  d.attributes = attrs;
  d.num_attributes = 3;
  const char *path = tmp_path("attrs.exr");
  REQUIRE(ch_exr_write(path, &img, &d, &err) == CH_OK);
  char value[128];
  CHECK(ch_exr_read_attribute(path, "chisel:command", value, sizeof value, &err) == CH_OK);
  CHECK(strcmp(value, attrs[0].value) == 0);
  CHECK(ch_exr_read_attribute(path, "chisel:version", value, sizeof value, &err) == CH_OK);
  CHECK(strcmp(value, "0.1.0") == 0);
  CHECK(ch_exr_read_attribute(path, "chisel:empty", value, sizeof value, &err) == CH_OK);
  CHECK(value[0] == '\0');
  /* truncated copy */
  char small[7];
  CHECK(ch_exr_read_attribute(path, "chisel:command", small, sizeof small, &err) == CH_OK);
  CHECK(strcmp(small, "chisel") == 0);
  /* absent, and present but not a string */
  CHECK(ch_exr_read_attribute(path, "chisel:nope", value, sizeof value, &err) == CH_ERR_INPUT);
  CHECK(message_ok(&err, "attrs.exr") && strstr(err.message, "chisel:nope"));
  CHECK(ch_exr_read_attribute(path, "compression", value, sizeof value, &err) == CH_ERR_INPUT);
  CHECK(message_ok(&err, "attrs.exr"));
  CHECK(ch_exr_read_attribute(tmp_path("no-such.exr"), "x", value, sizeof value, &err) ==
        CH_ERR_IO);

  /* An attribute the library refuses (a required attribute's name with the
   * wrong type) fails after the temporary file exists: it must go away. */
  ch_exr_attribute bad[1] = {{"compression", "zip"}};
  d.attributes = bad;
  d.num_attributes = 1;
  const char *badpath = tmp_path("badattr.exr");
  ch_status st = ch_exr_write(badpath, &img, &d, &err);
  CHECK(st != CH_OK);
  CHECK(message_ok(&err, "badattr.exr"));
  fprintf(stderr, "  (bad attribute message: %s)\n", err.message);
  CHECK(!file_exists(badpath));
  CHECK(count_leftovers("badattr.exr") == 0);
  ch_image_free(&img);
}

static void test_deterministic(void) {
  static const ch_exr_compression comps[] = {CH_EXR_NONE, CH_EXR_ZIP, CH_EXR_PIZ};
  ch_image img;
  ch_error err = {0};
  REQUIRE(ch_image_init(&img, 37, 23, 2, NULL, &err) == CH_OK);
  fill_image(&img, 1);
  ch_exr_type types[2] = {CH_EXR_FLOAT, CH_EXR_HALF};
  ch_exr_attribute attrs[1] = {{"chisel:command", "x"}};
  for (int k = 0; k < 3; k++) {
    ch_exr_write_desc d = {0};
    d.compression = comps[k];
    d.channel_types = types;
    d.attributes = attrs;
    d.num_attributes = 1;
    const char *p1 = tmp_path("det1.exr"), *p2 = tmp_path("det2.exr");
    CHECK(ch_exr_write(p1, &img, &d, &err) == CH_OK);
    CHECK(ch_exr_write(p2, &img, &d, &err) == CH_OK);
    size_t n1 = 0, n2 = 0;
    unsigned char *a = slurp(p1, &n1), *b = slurp(p2, &n2);
    CHECK(a && b && n1 == n2 && n1 > 0 && memcmp(a, b, n1) == 0);
    free(a);
    free(b);
  }
  /* PNG too */
  uint8_t px[5 * 4 * 3];
  for (size_t i = 0; i < sizeof px; i++) px[i] = (uint8_t)(i * 7);
  CHECK(ch_png_write(tmp_path("det1.png"), 5, 4, 3, px, &err) == CH_OK);
  CHECK(ch_png_write(tmp_path("det2.png"), 5, 4, 3, px, &err) == CH_OK);
  size_t n1 = 0, n2 = 0;
  unsigned char *a = slurp(tmp_path("det1.png"), &n1), *b = slurp(tmp_path("det2.png"), &n2);
  CHECK(a && b && n1 == n2 && memcmp(a, b, n1) == 0);
  free(a);
  free(b);
  ch_image_free(&img);
}

/* Expects a clean CH_ERR_INPUT naming the file, through both entry points. */
static int expect_input_error(const char *label, const unsigned char *data, size_t n,
                              int via_file) {
  ch_image img;
  ch_error err = {0};
  int ok = 1;
  ch_status st = ch_exr_read_memory(data, n, label, &img, &err);
  if (st != CH_ERR_INPUT || !message_ok(&err, label) || img.pixels) {
    fprintf(stderr, "  %s (%zu bytes, memory): status %d, message '%s'\n", label, n, (int)st,
            err.message);
    ok = 0;
  }
  ch_image_free(&img);
  if (via_file) {
    const char *path = tmp_path(label);
    if (!write_bytes(path, data, n)) return 0;
    st = ch_exr_read(path, &img, &err);
    if (st != CH_ERR_INPUT || !message_ok(&err, label)) {
      fprintf(stderr, "  %s (%zu bytes, file): status %d, message '%s'\n", label, n, (int)st,
              err.message);
      ok = 0;
    }
    ch_image_free(&img);
  }
  return ok;
}

static void test_malformed(void) {
  ch_error err = {0};
  /* empty file */
  CHECK(expect_input_error("empty.exr", (const unsigned char *)"", 0, 1));
  /* random garbage, and garbage behind a valid magic number + version */
  int bad = 0;
  for (int t = 0; t < 400; t++) {
    unsigned char buf[700];
    size_t n = rng() % sizeof buf;
    for (size_t i = 0; i < n; i++) buf[i] = (uint8_t)rng();
    if (t % 2 && n >= 8) memcpy(buf, "\x76\x2f\x31\x01\x02\x00\x00\x00", 8);
    if (!expect_input_error("garbage.exr", buf, n, t < 20)) bad++;
  }
  CHECK_MSG(bad == 0, "%d garbage inputs misreported", bad);

  /* found by fuzz/fuzz_exr.c: a channel named "\n" must not break the
   * one-line message rule */
  static const unsigned char newline_name[] = {
      0x76, 0x2f, 0x31, 0x01, 0x02, 0x00, 0x00, 0x00, 0x64, 0x61, 0x74, 0x61, 0x57, 0x69, 0x6e, 0x64,
      0x6f, 0x77, 0x00, 0x62, 0x6f, 0x78, 0x32, 0x69, 0x00, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
      0x00, 0x00, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00, 0x06, 0x00, 0x00, 0x00, 0x79, 0x57, 0x00,
      0x66, 0x9a, 0x00, 0x04, 0x00, 0x80, 0x3f, 0x63, 0x68, 0x61, 0x6e, 0x6e, 0x65, 0x6c, 0x73, 0x00,
      0x63, 0x68, 0x6c, 0x69, 0x73, 0x74, 0x00, 0x37, 0x00, 0x00, 0x00, 0x0a, 0x00, 0x00, 0x00, 0x00,
      0x00, 0x00, 0x00, 0x00, 0x00, 0x09, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x59, 0x00, 0x01,
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00,
      0x00, 0xde, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x2e, 0x02, 0x00, 0x00, 0x00, 0x00, 0x3f,
      0x00, 0x00, 0x3c};
  CHECK(expect_input_error("newline-name.exr", newline_name, sizeof newline_name, 0));
  /* also found by the fuzzer: a non-ASCII channel name (byte 0xd8) in the
   * "subsampled" message */
  static const unsigned char high_byte_name[] = {
      0x76, 0x2f, 0x31, 0x01, 0x02, 0x00, 0x00, 0x00, 0x64, 0x61, 0x74, 0x61, 0x57, 0x69, 0x6e, 0x64,
      0x6f, 0x77, 0x00, 0x62, 0x6f, 0x78, 0x32, 0x69, 0x00, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
      0x00, 0x00, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00, 0x06, 0x00, 0x00, 0x00, 0x79, 0x57, 0x00,
      0x9a, 0x00, 0x04, 0x00, 0x80, 0x3f, 0x63, 0x68, 0x61, 0x6e, 0x6e, 0x65, 0x6c, 0x73, 0x00, 0x63,
      0x68, 0x6c, 0x69, 0x73, 0x74, 0x00, 0x12, 0x00, 0x00, 0x00, 0xd8, 0x00, 0x02, 0x00, 0x00, 0x00,
      0x00, 0x00, 0x00, 0x00, 0x09, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00};
  CHECK(expect_input_error("high-byte-name.exr", high_byte_name, sizeof high_byte_name, 0));

  /* a PNG renamed .exr */
  uint8_t px[4 * 4 * 3] = {0};
  REQUIRE(ch_png_write(tmp_path("png-in-disguise.exr"), 4, 4, 3, px, &err) == CH_OK);
  ch_image img;
  CHECK(ch_exr_read(tmp_path("png-in-disguise.exr"), &img, &err) == CH_ERR_INPUT);
  CHECK(message_ok(&err, "png-in-disguise.exr"));

  /* a directory and a missing file are i/o errors */
  CHECK(ch_exr_read(tmpdir, &img, &err) == CH_ERR_IO);
  CHECK(ch_exr_read(tmp_path("missing.exr"), &img, &err) == CH_ERR_IO);
  CHECK(message_ok(&err, "missing.exr"));

  /* every prefix of small valid files, every compression; and single-byte
   * corruptions everywhere (must not crash; any error must be clean) */
  static const ch_exr_compression comps[] = {CH_EXR_NONE, CH_EXR_ZIP, CH_EXR_PIZ};
  for (int k = 0; k < 3; k++) {
    ch_image src;
    REQUIRE(ch_image_init(&src, 5, 3, 2, NULL, &err) == CH_OK);
    fill_image(&src, 0);
    ch_exr_type types[2] = {CH_EXR_HALF, CH_EXR_FLOAT};
    ch_exr_write_desc d = {0};
    d.compression = comps[k];
    d.channel_types = types;
    const char *path = tmp_path("small.exr");
    REQUIRE(ch_exr_write(path, &src, &d, &err) == CH_OK);
    size_t n = 0;
    unsigned char *data = slurp(path, &n);
    REQUIRE(data);
    int prefix_bad = 0;
    for (size_t len = 0; len < n; len++)
      if (!expect_input_error("truncated.exr", data, len, len % 16 == 0)) prefix_bad++;
    CHECK_MSG(prefix_bad == 0, "%s: %d of %zu prefixes misreported", comp_name(comps[k]),
              prefix_bad, n);
    /* the whole file is fine */
    CHECK(ch_exr_read_memory(data, n, "whole.exr", &img, &err) == CH_OK);
    ch_image_free(&img);
    int flip_bad = 0;
    static const uint8_t patterns[4] = {0xff, 0x01, 0x80, 0x00};
    for (size_t i = 0; i < n; i++) {
      for (int p = 0; p < 4; p++) {
        unsigned char saved = data[i];
        data[i] = p == 3 ? 0 : (unsigned char)(data[i] ^ patterns[p]);
        ch_status st = ch_exr_read_memory(data, n, "flipped.exr", &img, &err);
        if (st != CH_OK && (st != CH_ERR_INPUT || !message_ok(&err, "flipped.exr"))) {
          if (flip_bad++ < 3)
            fprintf(stderr, "  byte %zu pattern %d: status %d '%s'\n", i, p, (int)st,
                    err.message);
        }
        ch_image_free(&img);
        data[i] = saved;
      }
    }
    CHECK_MSG(flip_bad == 0, "%s: %d corruptions misreported", comp_name(comps[k]), flip_bad);
    free(data);
    ch_image_free(&src);
  }
}

static void test_write_errors(void) {
  ch_image img;
  ch_error err = {0};
  REQUIRE(ch_image_init(&img, 3, 3, 1, NULL, &err) == CH_OK);
  const char *dir = tmp_path("no-such-dir");
  char path[700];
  snprintf(path, sizeof path, "%s/out.exr", dir);
  CHECK(ch_exr_write(path, &img, NULL, &err) == CH_ERR_IO);
  CHECK(message_ok(&err, "out.exr"));
  CHECK(!file_exists(path) && !file_exists(dir));
  snprintf(path, sizeof path, "%s/out.png", dir);
  uint8_t px[27] = {0};
  CHECK(ch_png_write(path, 3, 3, 3, px, &err) == CH_ERR_IO);
  CHECK(message_ok(&err, "out.png"));
  CHECK(!file_exists(path) && !file_exists(dir));
  snprintf(path, sizeof path, "%s/out.png", dir);
  float h[9] = {0};
  CHECK(ch_png_write_height(path, h, 3, 3, &err) == CH_ERR_IO);
  CHECK(!file_exists(path));
  /* an existing file is replaced only by a complete new one */
  const char *keep = tmp_path("keep.exr");
  REQUIRE(ch_exr_write(keep, &img, NULL, &err) == CH_OK);
  ch_exr_write_desc d = {0};
  d.compression = (ch_exr_compression)99;
  CHECK(ch_exr_write(keep, &img, &d, &err) == CH_ERR_INPUT);
  ch_image back;
  CHECK(ch_exr_read(keep, &back, &err) == CH_OK);
  ch_image_free(&back);
  ch_image_free(&img);
}

/* ------------------------------------------------------------------------ */
/* Hand-built EXR files.                                                    */

typedef struct bytes {
  unsigned char *p;
  size_t n, cap;
} bytes;

static void put(bytes *b, const void *d, size_t n) {
  if (b->n + n > b->cap) {
    b->cap = (b->n + n) * 2 + 64;
    b->p = realloc(b->p, b->cap);
    if (!b->p) abort();
  }
  memcpy(b->p + b->n, d, n);
  b->n += n;
}
static void put_u8(bytes *b, unsigned v) {
  unsigned char c = (unsigned char)v;
  put(b, &c, 1);
}
static void put_u32(bytes *b, uint32_t v) {
  unsigned char c[4] = {(unsigned char)v, (unsigned char)(v >> 8), (unsigned char)(v >> 16),
                        (unsigned char)(v >> 24)};
  put(b, c, 4);
}
static void put_i32(bytes *b, int32_t v) { put_u32(b, (uint32_t)v); }
static void put_u64(bytes *b, uint64_t v) {
  put_u32(b, (uint32_t)v);
  put_u32(b, (uint32_t)(v >> 32));
}
static void put_f32(bytes *b, float f) { put_u32(b, float_bits(f)); }
static void put_str(bytes *b, const char *s) { put(b, s, strlen(s) + 1); }
static void put_u16(bytes *b, unsigned v) {
  put_u8(b, v & 0xff);
  put_u8(b, (v >> 8) & 0xff);
}
static void set_u64(bytes *b, size_t at, uint64_t v) {
  for (int i = 0; i < 8; i++) b->p[at + i] = (unsigned char)(v >> (8 * i));
}

/* Half bits of a small non-negative integer (exact). */
static unsigned half_of_int(unsigned n) {
  if (n == 0) return 0;
  int e = 0;
  while ((n >> (e + 1)) != 0) e++;
  unsigned mant = (e <= 10 ? (n << (10 - e)) : (n >> (e - 10))) & 0x3ffu;
  return (unsigned)((e + 15) << 10) | mant;
}

typedef struct chan_def {
  const char *name;
  int type; /* 0 uint, 1 half, 2 float */
} chan_def;

/* Expected texel values of the hand-built files, in image coordinates.
 * Types 3 and 4 (float and half values stored as types 2 and 1) come in
 * runs, for the ZIPS file. */
static float hb_value(int type, int x, int y) {
  switch (type) {
  case 0: return (float)(1000 + 7 * x + 100 * y);
  case 1: return (float)(x + 5 * y);
  case 3: return x < 9 ? 1.5f : (float)(x / 4) + 0.125f * (float)y;
  case 4: return (float)(y + (x > 13 ? x : 0));
  default: return (float)x + 0.25f + 10.0f * (float)y;
  }
}
static int hb_storage(int type) { return type == 3 ? 2 : type == 4 ? 1 : type; }

static void put_header(bytes *b, uint32_t flags, const chan_def *ch, int nch, int comp,
                       int x0, int y0, int x1, int y1) {
  put_u32(b, 20000630u);
  put_u32(b, 2u | flags);
  int32_t size = 1;
  for (int c = 0; c < nch; c++) size += (int32_t)strlen(ch[c].name) + 1 + 16;
  put_str(b, "channels");
  put_str(b, "chlist");
  put_i32(b, size);
  for (int c = 0; c < nch; c++) {
    put_str(b, ch[c].name);
    put_i32(b, hb_storage(ch[c].type));
    put_u8(b, 0);
    put_u8(b, 0);
    put_u8(b, 0);
    put_u8(b, 0);
    put_i32(b, 1);
    put_i32(b, 1);
  }
  put_u8(b, 0);
  put_str(b, "compression");
  put_str(b, "compression");
  put_i32(b, 1);
  put_u8(b, (unsigned)comp);
  put_str(b, "dataWindow");
  put_str(b, "box2i");
  put_i32(b, 16);
  put_i32(b, x0);
  put_i32(b, y0);
  put_i32(b, x1);
  put_i32(b, y1);
  put_str(b, "displayWindow");
  put_str(b, "box2i");
  put_i32(b, 16);
  put_i32(b, 0);
  put_i32(b, 0);
  put_i32(b, 9);
  put_i32(b, 9);
  put_str(b, "lineOrder");
  put_str(b, "lineOrder");
  put_i32(b, 1);
  put_u8(b, 0);
  put_str(b, "pixelAspectRatio");
  put_str(b, "float");
  put_i32(b, 4);
  put_f32(b, 1.0f);
  put_str(b, "screenWindowCenter");
  put_str(b, "v2f");
  put_i32(b, 8);
  put_f32(b, 0.0f);
  put_f32(b, 0.0f);
  put_str(b, "screenWindowWidth");
  put_str(b, "float");
  put_i32(b, 4);
  put_f32(b, 1.0f);
}


static void put_sample(bytes *b, int type, int x, int y) {
  int st = hb_storage(type);
  if (st == 0) put_u32(b, (uint32_t)hb_value(type, x, y));
  else if (st == 1) put_u16(b, half_of_int((unsigned)hb_value(type, x, y)));
  else put_f32(b, hb_value(type, x, y));
}

static void check_hand_built(const char *label, const ch_image *img, const chan_def *ch,
                             int nch, int w, int h) {
  CHECK_MSG(img->width == w && img->height == h && img->num_channels == nch, "%s: %dx%dx%d",
            label, img->width, img->height, img->num_channels);
  if (img->width != w || img->height != h) return;
  for (int c = 0; c < nch; c++) {
    int ic = ch_image_find(img, ch[c].name);
    CHECK_MSG(ic >= 0, "%s: channel %s", label, ch[c].name);
    if (ic < 0) continue;
    int bad = 0;
    for (int y = 0; y < h; y++)
      for (int x = 0; x < w; x++)
        if (ch_image_plane(img, ic)[(size_t)y * w + x] != hb_value(ch[c].type, x, y)) bad++;
    CHECK_MSG(bad == 0, "%s: channel %s has %d wrong texels", label, ch[c].name, bad);
  }
}

static void test_hand_built_scanline(void) {
  /* data window (-2,3)-(2,5): 5x3, uncompressed, one line per chunk */
  const chan_def ch[2] = {{"H", 1}, {"U", 0}};
  const int W = 5, H = 3;
  bytes b = {0};
  put_header(&b, 0, ch, 2, 0, -2, 3, 2, 5);
  put_u8(&b, 0); /* end of header */
  size_t table = b.n;
  for (int i = 0; i < H; i++) put_u64(&b, 0);
  for (int y = 0; y < H; y++) {
    set_u64(&b, table + 8 * (size_t)y, b.n);
    put_i32(&b, 3 + y);
    put_i32(&b, W * (2 + 4));
    for (int c = 0; c < 2; c++)
      for (int x = 0; x < W; x++) put_sample(&b, ch[c].type, x, y);
  }
  ch_image img;
  ch_error err = {0};
  ch_status st = ch_exr_read_memory(b.p, b.n, "scan.exr", &img, &err);
  CHECK_MSG(st == CH_OK, "%s", err.message);
  if (st == CH_OK) check_hand_built("scanline", &img, ch, 2, W, H);
  ch_image_free(&img);
  /* every prefix fails cleanly */
  int bad = 0;
  for (size_t len = 0; len < b.n; len++)
    if (!expect_input_error("scan-prefix.exr", b.p, len, 0)) bad++;
  CHECK(bad == 0);

  /* an uncompressed chunk that claims fewer bytes than its lines need
   * (the file is padded so that every read stays inside it) */
  size_t size_at = table + 8 * (size_t)H + 4; /* first chunk's size field */
  b.p[size_at] = (unsigned char)(W * 6 - 10);
  for (int i = 0; i < 64; i++) put_u8(&b, 0);
  CHECK(expect_input_error("short-chunk.exr", b.p, b.n, 0));
  ch_exr_read_memory(b.p, b.n, "short-chunk.exr", &img, &err);
  fprintf(stderr, "  (short chunk: %s)\n", err.message);
  free(b.p);
}

static void test_hand_built_tiled(void) {
  /* data window (10,-5)-(14,-1): 5x5 in 2x3 tiles (3 x 2 tiles, partial at
   * the right and bottom), float + half + uint, uncompressed. */
  const chan_def ch[3] = {{"F", 2}, {"H", 1}, {"U", 0}};
  const int W = 5, H = 5, TW = 2, TH = 3, NTX = 3, NTY = 2;
  bytes b = {0};
  put_header(&b, 0x200, ch, 3, 0, 10, -5, 14, -1);
  put_str(&b, "tiles");
  put_str(&b, "tiledesc");
  put_i32(&b, 9);
  put_u32(&b, TW);
  put_u32(&b, TH);
  put_u8(&b, 0); /* ONE_LEVEL, ROUND_DOWN */
  put_u8(&b, 0);
  size_t table = b.n;
  for (int i = 0; i < NTX * NTY; i++) put_u64(&b, 0);
  for (int ty = 0; ty < NTY; ty++)
    for (int tx = 0; tx < NTX; tx++) {
      int x0 = tx * TW, y0 = ty * TH;
      int w = W - x0 < TW ? W - x0 : TW, h = H - y0 < TH ? H - y0 : TH;
      set_u64(&b, table + 8 * (size_t)(ty * NTX + tx), b.n);
      put_i32(&b, tx);
      put_i32(&b, ty);
      put_i32(&b, 0);
      put_i32(&b, 0);
      put_i32(&b, w * h * (4 + 2 + 4));
      for (int y = y0; y < y0 + h; y++)
        for (int c = 0; c < 3; c++)
          for (int x = x0; x < x0 + w; x++) put_sample(&b, ch[c].type, x, y);
    }
  ch_image img;
  ch_error err = {0};
  ch_status st = ch_exr_read_memory(b.p, b.n, "tiled.exr", &img, &err);
  CHECK_MSG(st == CH_OK, "%s", err.message);
  if (st == CH_OK) check_hand_built("tiled", &img, ch, 3, W, H);
  ch_image_free(&img);
  int bad = 0;
  for (size_t len = 0; len < b.n; len++)
    if (!expect_input_error("tiled-prefix.exr", b.p, len, 0)) bad++;
  CHECK(bad == 0);
  free(b.p);
}

/* A tiny zlib writer (RFC 1950/1951): one fixed-Huffman block with only
 * literals and distance-1 matches (run-length coding), so the ZIP test
 * files below are built without zlib and still come out smaller than the
 * raw data (OpenEXR readers refuse chunks larger than their raw size). */
typedef struct bitw {
  bytes *b;
  uint32_t acc;
  int n;
} bitw;
static void bits_put(bitw *w, uint32_t v, int count) { /* LSB first */
  for (int i = 0; i < count; i++) {
    w->acc |= ((v >> i) & 1u) << w->n;
    if (++w->n == 8) {
      put_u8(w->b, w->acc);
      w->acc = 0;
      w->n = 0;
    }
  }
}
static void huff_put(bitw *w, uint32_t code, int len) { /* Huffman codes MSB first */
  for (int i = len - 1; i >= 0; i--) bits_put(w, (code >> i) & 1u, 1);
}
static void fixed_symbol(bitw *w, unsigned sym) {
  if (sym < 144) huff_put(w, 0x30 + sym, 8);
  else if (sym < 256) huff_put(w, 0x190 + (sym - 144), 9);
  else if (sym < 280) huff_put(w, sym - 256, 7);
  else huff_put(w, 0xc0 + (sym - 280), 8);
}
static void put_zlib_rle(bytes *b, const unsigned char *in, size_t n) {
  static const unsigned base[29] = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                    31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
  static const int extra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
  put_u8(b, 0x78);
  put_u8(b, 0x01);
  bitw w = {b, 0, 0};
  bits_put(&w, 1, 1); /* BFINAL */
  bits_put(&w, 1, 2); /* BTYPE = 01, fixed Huffman */
  for (size_t i = 0; i < n;) {
    size_t run = 0;
    while (i > 0 && i + run < n && run < 258 && in[i + run] == in[i - 1]) run++;
    if (run >= 3) {
      int k = 28;
      while (base[k] > run) k--;
      fixed_symbol(&w, 257u + (unsigned)k);
      bits_put(&w, (uint32_t)(run - base[k]), extra[k]);
      huff_put(&w, 0, 5); /* distance code 0: distance 1 */
      i += run;
    } else {
      fixed_symbol(&w, in[i]);
      i++;
    }
  }
  fixed_symbol(&w, 256); /* end of block */
  if (w.n) put_u8(b, w.acc);
  uint32_t a = 1, s = 0;
  for (size_t i = 0; i < n; i++) {
    a = (a + in[i]) % 65521u;
    s = (s + a) % 65521u;
  }
  uint32_t adler = (s << 16) | a;
  for (int i = 3; i >= 0; i--) put_u8(b, (adler >> (8 * i)) & 0xff);
}

/* A ZIPS file (one line per chunk) built here: data window (3,-2)-(25,1),
 * channels F (float) and H (half); the EXR ZIP transform (interleave the
 * even and odd bytes, then delta-predict) is applied by this code. */
static const chan_def zips_ch[2] = {{"F", 3}, {"H", 4}};
enum { ZIPS_W = 23, ZIPS_H = 4 };
static void build_zips_file_short(bytes *b, size_t cut) {
  put_header(b, 0, zips_ch, 2, 2 /* ZIPS */, 3, -2, 3 + ZIPS_W - 1, ZIPS_H - 3);
  put_u8(b, 0);
  size_t table = b->n;
  for (int i = 0; i < ZIPS_H; i++) put_u64(b, 0);
  for (int y = 0; y < ZIPS_H; y++) {
    bytes raw = {0};
    for (int c = 0; c < 2; c++)
      for (int x = 0; x < ZIPS_W; x++) put_sample(&raw, zips_ch[c].type, x, y);
    size_t n = raw.n, half = (n + 1) / 2;
    unsigned char *t = malloc(n);
    if (!t) abort();
    for (size_t i = 0; i < n; i++) t[(i % 2) ? half + i / 2 : i / 2] = raw.p[i];
    for (size_t i = n - 1; i > 0; i--) t[i] = (unsigned char)(t[i] - t[i - 1] + 128);
    bytes z = {0};
    put_zlib_rle(&z, t, y == 1 ? n - cut : n); /* cut > 0: a stream that inflates short */
    set_u64(b, table + 8 * (size_t)y, b->n);
    put_i32(b, -2 + y);
    put_i32(b, (int32_t)z.n);
    put(b, z.p, z.n);
    free(z.p);
    free(t);
    free(raw.p);
  }
}

static void build_zips_file(bytes *b) { build_zips_file_short(b, 0); }

static void test_hand_built_zips(void) {
  bytes b = {0};
  build_zips_file(&b);
  ch_image img;
  ch_error err = {0};
  ch_status st = ch_exr_read_memory(b.p, b.n, "zips.exr", &img, &err);
  CHECK_MSG(st == CH_OK, "%s", err.message);
  if (st == CH_OK) check_hand_built("zips", &img, zips_ch, 2, ZIPS_W, ZIPS_H);
  ch_image_free(&img);
  int bad = 0;
  for (size_t len = 0; len < b.n; len++)
    if (!expect_input_error("zips-prefix.exr", b.p, len, 0)) bad++;
  CHECK(bad == 0);
  free(b.p);
  /* a valid zlib stream that inflates to fewer bytes than the lines need */
  for (size_t cut = 1; cut <= 9; cut += 4) {
    bytes s = {0};
    build_zips_file_short(&s, cut);
    st = ch_exr_read_memory(s.p, s.n, "zips-short.exr", &img, &err);
    fprintf(stderr, "  (short inflate by %zu: status %d %s)\n", cut, (int)st,
            st ? err.message : "");
    CHECK(st == CH_ERR_INPUT && message_ok(&err, "zips-short.exr"));
    ch_image_free(&img);
    free(s.p);
  }
}

static void test_hand_built_refusals(void) {
  const chan_def ch[1] = {{"Y", 2}};
  ch_error err = {0};
  ch_image img;
  /* wider than CH_IMAGE_MAX_SIDE */
  {
    bytes b = {0};
    put_header(&b, 0, ch, 1, 0, 0, 0, 40000, 0);
    put_u8(&b, 0);
    put_u64(&b, (uint64_t)b.n + 8);
    put_i32(&b, 0);
    put_i32(&b, 4);
    put_f32(&b, 1.0f);
    CHECK(expect_input_error("wide.exr", b.p, b.n, 1));
    free(b.p);
  }
  /* 32768 x 32768 x 64 channels claimed by a file of a few hundred bytes */
  {
    chan_def many[64];
    char names[64][4];
    for (int c = 0; c < 64; c++) {
      snprintf(names[c], sizeof names[c], "%c%c", 'A' + c / 26, 'A' + c % 26);
      many[c].name = names[c];
      many[c].type = 2;
    }
    bytes b = {0};
    put_header(&b, 0, many, 64, 3, 0, 0, 32767, 32767);
    put_u8(&b, 0);
    for (int i = 0; i < 16; i++) put_u64(&b, 0);
    CHECK(expect_input_error("huge.exr", b.p, b.n, 0));
    /* the same with a complete offset table: refused by the size check */
    for (int i = 16; i < 32768 / 16; i++) put_u64(&b, 0);
    CHECK(expect_input_error("huge.exr", b.p, b.n, 0));
    ch_exr_read_memory(b.p, b.n, "huge.exr", &img, &err);
    fprintf(stderr, "  (huge: %s)\n", err.message);
    CHECK(strstr(err.message, "implausible") != NULL);
    free(b.p);
  }
  /* deep scanline */
  {
    bytes b = {0};
    put_header(&b, 0x800, ch, 1, 0, 0, 0, 3, 3);
    put_str(&b, "type");
    put_str(&b, "string");
    put_i32(&b, 12);
    put(&b, "deepscanline", 12);
    put_str(&b, "version");
    put_str(&b, "int");
    put_i32(&b, 4);
    put_i32(&b, 1);
    put_str(&b, "chunkCount");
    put_str(&b, "int");
    put_i32(&b, 4);
    put_i32(&b, 4);
    put_str(&b, "maxSamplesPerPixel");
    put_str(&b, "int");
    put_i32(&b, 4);
    put_i32(&b, 1);
    put_u8(&b, 0);
    for (int i = 0; i < 4; i++) put_u64(&b, 0);
    for (int i = 0; i < 64; i++) put_u8(&b, 0);
    CHECK(expect_input_error("deep.exr", b.p, b.n, 1));
    ch_exr_read_memory(b.p, b.n, "deep.exr", &img, &err);
    fprintf(stderr, "  (deep: %s)\n", err.message);
    CHECK(strstr(err.message, "deep") != NULL);
    free(b.p);
  }
}

/* ------------------------------------------------------------------------ */
/* PNG                                                                      */

static void test_png_roundtrip(void) {
  for (int nc = 3; nc <= 4; nc++) {
    int w = 13, h = 7;
    uint8_t *px = malloc((size_t)w * h * nc);
    REQUIRE(px);
    for (int i = 0; i < w * h * nc; i++) px[i] = (uint8_t)rng();
    ch_error err = {0};
    const char *path = tmp_path(nc == 3 ? "rt.png" : "rt4.png");
    CHECK_MSG(ch_png_write(path, w, h, nc, px, &err) == CH_OK, "%s", err.message);
    int rw, rh, rc;
    uint8_t *back = NULL;
    CHECK_MSG(ch_png_read(path, &rw, &rh, &rc, &back, &err) == CH_OK, "%s", err.message);
    CHECK(rw == w && rh == h && rc == nc);
    CHECK(back && memcmp(px, back, (size_t)w * h * nc) == 0);
    free(back);
    free(px);
  }
  /* not a PNG, truncated PNG */
  ch_error err = {0};
  int rw, rh, rc;
  uint8_t *back = NULL;
  ch_image img;
  REQUIRE(ch_image_init(&img, 2, 2, 1, NULL, &err) == CH_OK);
  REQUIRE(ch_exr_write(tmp_path("exr-as.png"), &img, NULL, &err) == CH_OK);
  ch_image_free(&img);
  CHECK(ch_png_read(tmp_path("exr-as.png"), &rw, &rh, &rc, &back, &err) == CH_ERR_INPUT);
  CHECK(message_ok(&err, "exr-as.png") && back == NULL);
  size_t n = 0;
  unsigned char *data = slurp(tmp_path("rt.png"), &n);
  REQUIRE(data);
  int bad = 0;
  for (size_t len = 0; len < n; len++) {
    write_bytes(tmp_path("cut.png"), data, len);
    ch_status st = ch_png_read(tmp_path("cut.png"), &rw, &rh, &rc, &back, &err);
    if (st != CH_ERR_INPUT || !message_ok(&err, "cut.png") || back) bad++;
    free(back);
    back = NULL;
  }
  CHECK_MSG(bad == 0, "%d truncated PNGs misreported", bad);
  free(data);
}

static int lum(const uint8_t c[3]) { return 2 * c[0] + 7 * c[1] + c[2]; }

static void test_colormaps(void) {
  uint8_t lo[3], mid[3], hi[3], t[3];
  ch_colormap_diverging(-1.0, lo);
  ch_colormap_diverging(0.0, mid);
  ch_colormap_diverging(1.0, hi);
  CHECK(lo[2] > lo[0] + 50 && lo[2] > lo[1]); /* blue */
  CHECK(hi[0] > hi[2] + 50 && hi[0] > hi[1]); /* red */
  CHECK(mid[0] >= 240 && mid[1] >= 240 && mid[2] >= 240); /* white-ish */
  ch_colormap_diverging(-7.0, t);
  CHECK(memcmp(t, lo, 3) == 0);
  ch_colormap_diverging(7.0, t);
  CHECK(memcmp(t, hi, 3) == 0);
  ch_colormap_diverging(NAN, t);
  CHECK(memcmp(t, mid, 3) == 0);
  /* lightness falls away from 0 on both sides */
  uint8_t a[3], b[3];
  for (double x = 0.0; x < 0.95; x += 0.1) {
    ch_colormap_diverging(x, a);
    ch_colormap_diverging(x + 0.1, b);
    CHECK(lum(b) <= lum(a));
    ch_colormap_diverging(-x, a);
    ch_colormap_diverging(-x - 0.1, b);
    CHECK(lum(b) <= lum(a));
  }
  ch_colormap_heat(0.0, lo);
  ch_colormap_heat(0.5, mid);
  ch_colormap_heat(1.0, hi);
  CHECK(lo[0] < 60 && lo[1] < 60 && lo[2] < 60);       /* dark */
  CHECK(mid[1] > 200 && mid[1] > mid[0] && mid[1] > mid[2]); /* green-yellow */
  CHECK(hi[0] > 100 && hi[1] < 40 && hi[2] < 40);     /* dark red */
  ch_colormap_heat(-3.0, t);
  CHECK(memcmp(t, lo, 3) == 0);
  ch_colormap_heat(3.0, t);
  CHECK(memcmp(t, hi, 3) == 0);
  ch_colormap_heat(NAN, t);
  CHECK(memcmp(t, lo, 3) == 0);
}

static void test_height_preview(void) {
  ch_error err = {0};
  int W = 16, H = 12, rw, rh, rc;
  float *h = calloc((size_t)W * H, sizeof(float));
  REQUIRE(h);
  uint8_t *px = NULL;
  /* all zero: uniform white-ish */
  const char *path = tmp_path("flat.png");
  CHECK(ch_png_write_height(path, h, W, H, &err) == CH_OK);
  REQUIRE(ch_png_read(path, &rw, &rh, &rc, &px, &err) == CH_OK);
  CHECK(rw == W && rh == H && rc == 3);
  int uniform = 1;
  for (int i = 0; i < W * H * 3; i++) uniform &= px[i] == px[i % 3] && px[i] >= 240;
  CHECK(uniform);
  free(px);
  /* a raised block on the left, a carved block on the right */
  for (int y = 3; y < 9; y++)
    for (int x = 0; x < W; x++) {
      if (x >= 2 && x < 6) h[y * W + x] = 0.5f;
      if (x >= 9 && x < 14) h[y * W + x] = -1.0f;
    }
  path = tmp_path("blocks.png");
  CHECK(ch_png_write_height(path, h, W, H, &err) == CH_OK);
  REQUIRE(ch_png_read(path, &rw, &rh, &rc, &px, &err) == CH_OK);
#define PX(x, y) (px + ((size_t)(y) * W + (x)) * 3)
  CHECK(PX(3, 5)[0] > PX(3, 5)[2] + 30);   /* raised interior: red */
  CHECK(PX(11, 5)[2] > PX(11, 5)[0] + 30); /* carved interior: blue */
  /* the raised block's left wall faces the light, its right wall does not */
  CHECK(lum(PX(2, 5)) > lum(PX(5, 5)) + 100);
  /* carved: the far (right) wall faces the light */
  CHECK(lum(PX(13, 5)) > lum(PX(9, 5)) + 100);
  /* the flat ground far away stays white-ish */
  CHECK(PX(0, 0)[0] >= 240 && PX(0, 0)[2] >= 240);
#undef PX
  free(px);
  /* non-finite values are flagged, not fatal */
  h[0] = NAN;
  h[1] = INFINITY;
  CHECK(ch_png_write_height(tmp_path("nan.png"), h, W, H, &err) == CH_OK);
  free(h);
}

/* ------------------------------------------------------------------------ */
/* Modes used by other ctests.                                              */

/* Sample files for tests/tools/exr_read.py, with expected values as float
 * bit patterns (half channels hold the float that was written; the Python
 * side rounds it to half itself). */
static int write_exr_samples(const char *dir) {
  typedef struct sample {
    const char *file;
    int w, h, nc;
    ch_exr_compression comp;
    const char *names[4];
    ch_exr_type types[4];
    int pattern; /* 0 smooth, 1 random */
  } sample;
  static const sample samples[] = {
      {"s_none.exr", 37, 23, 3, CH_EXR_NONE, {"R", "G", "B"}, {0, 0, 0}, 0},
      {"s_zip.exr", 37, 23, 3, CH_EXR_ZIP, {"height", "mask", "A"}, {0, 1, 0}, 0},
      {"s_zip_1x1.exr", 1, 1, 1, CH_EXR_ZIP, {"Y"}, {0}, 0},
      {"s_zip_big.exr", 301, 70, 2, CH_EXR_ZIP, {"Z", "dx"}, {0, 1}, 0},
      {"s_zip_random.exr", 40, 20, 2, CH_EXR_ZIP, {"r", "s"}, {0, 1}, 1},
      {"s_half.exr", 20, 17, 4, CH_EXR_ZIP, {"R", "G", "B", "A"}, {1, 1, 1, 1}, 0},
      {"s_none_half.exr", 8, 3, 2, CH_EXR_NONE, {"a", "b"}, {1, 0}, 1},
  };
  char path[1024];
  snprintf(path, sizeof path, "%s/expected.txt", dir);
  mkdir(dir, 0777);
  FILE *fp = fopen(path, "w");
  if (!fp) {
    fprintf(stderr, "cannot write %s\n", path);
    return 1;
  }
  for (size_t s = 0; s < sizeof samples / sizeof samples[0]; s++) {
    const sample *sm = &samples[s];
    ch_image img;
    ch_error err = {0};
    if (ch_image_init(&img, sm->w, sm->h, sm->nc, sm->names, &err) != CH_OK) return 1;
    for (int c = 0; c < sm->nc; c++)
      for (int y = 0; y < sm->h; y++)
        for (int x = 0; x < sm->w; x++) {
          float v = sm->pattern ? rnd_float() * 1000.0f
                                : (float)(0.01 * x - 0.02 * y + 0.5 * c + 0.001 * x * y);
          ch_image_plane(&img, c)[(size_t)y * sm->w + x] = v;
        }
    ch_exr_attribute attrs[1] = {{"chisel:test", "hello"}};
    ch_exr_write_desc d = {0};
    d.compression = sm->comp;
    d.channel_types = sm->types;
    d.attributes = attrs;
    d.num_attributes = 1;
    snprintf(path, sizeof path, "%s/%s", dir, sm->file);
    if (ch_exr_write(path, &img, &d, &err) != CH_OK) {
      fprintf(stderr, "%s\n", err.message);
      return 1;
    }
    fprintf(fp, "file %s %d %d %s\n", sm->file, sm->w, sm->h,
            sm->comp == CH_EXR_NONE ? "NONE" : "ZIP");
    for (int c = 0; c < sm->nc; c++) {
      fprintf(fp, "channel %s %s\n", sm->names[c], sm->types[c] == CH_EXR_HALF ? "HALF" : "FLOAT");
      for (int y = 0; y < sm->h; y++) {
        for (int x = 0; x < sm->w; x++)
          fprintf(fp, "%s%08x", x ? " " : "",
                  (unsigned)float_bits(ch_image_plane(&img, c)[(size_t)y * sm->w + x]));
        fputc('\n', fp);
      }
    }
    ch_image_free(&img);
  }
  /* the hand-built ZIPS file (our writer has no ZIPS) */
  bytes b = {0};
  build_zips_file(&b);
  snprintf(path, sizeof path, "%s/s_zips_hand.exr", dir);
  if (!write_bytes(path, b.p, b.n)) return 1;
  free(b.p);
  fprintf(fp, "file s_zips_hand.exr %d %d ZIPS\n", ZIPS_W, ZIPS_H);
  for (int c = 0; c < 2; c++) {
    fprintf(fp, "channel %s %s\n", zips_ch[c].name,
            hb_storage(zips_ch[c].type) == 1 ? "HALF" : "FLOAT");
    for (int y = 0; y < ZIPS_H; y++) {
      for (int x = 0; x < ZIPS_W; x++)
        fprintf(fp, "%s%08x", x ? " " : "", (unsigned)float_bits(hb_value(zips_ch[c].type, x, y)));
      fputc('\n', fp);
    }
  }
  fprintf(fp, "end\n");
  return fclose(fp) == 0 ? 0 : 1;
}

static int compare_exr(const char *a, const char *b) {
  ch_image ia, ib;
  ch_error err = {0};
  if (ch_exr_read(a, &ia, &err) != CH_OK || ch_exr_read(b, &ib, &err) != CH_OK) {
    fprintf(stderr, "%s\n", err.message);
    return 1;
  }
  int bad = ia.width != ib.width || ia.height != ib.height || ia.num_channels != ib.num_channels;
  for (int c = 0; c < ia.num_channels && !bad; c++) {
    int k = ch_image_find(&ib, ia.names[c]);
    if (k < 0 || !planes_bit_equal(&ia, c, &ib, k)) {
      fprintf(stderr, "channel %s differs\n", ia.names[c]);
      bad = 1;
    }
  }
  if (bad) fprintf(stderr, "%s and %s differ\n", a, b);
  else fprintf(stderr, "%s and %s: %dx%d, %d channels, identical\n", a, b, ia.width, ia.height,
               ia.num_channels);
  ch_image_free(&ia);
  ch_image_free(&ib);
  return bad;
}

static void remove_tree(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return;
  struct dirent *e;
  char path[1200];
  while ((e = readdir(d)) != NULL) {
    if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
    snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
    remove(path);
  }
  closedir(d);
  rmdir(dir);
}

int main(int argc, char **argv) {
  if (argc == 3 && strcmp(argv[1], "--write-exr-samples") == 0)
    return write_exr_samples(argv[2]);
  if (argc == 4 && strcmp(argv[1], "--compare-exr") == 0) return compare_exr(argv[2], argv[3]);
  const char *base = getenv("TMPDIR");
  snprintf(tmpdir, sizeof tmpdir, "%s/test_image.XXXXXX", base && *base ? base : "/tmp");
  if (!mkdtemp(tmpdir)) {
    fprintf(stderr, "cannot create a temporary directory: %s\n", strerror(errno));
    return 1;
  }
  RUN(test_float_roundtrip);
  RUN(test_mixed_half_float);
  RUN(test_names_and_order);
  RUN(test_attributes);
  RUN(test_deterministic);
  RUN(test_malformed);
  RUN(test_write_errors);
  RUN(test_hand_built_scanline);
  RUN(test_hand_built_tiled);
  RUN(test_hand_built_zips);
  RUN(test_hand_built_refusals);
  RUN(test_png_roundtrip);
  RUN(test_colormaps);
  RUN(test_height_preview);
  if (ch_test_failures == 0) remove_tree(tmpdir);
  else fprintf(stderr, "files kept in %s\n", tmpdir);
  TEST_MAIN_END();
}
