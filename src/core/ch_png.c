/* ch_png: PNG previews through libpng, and the colour maps for them.
 *
 * - ch_colormap_heat: Anton Mikhailov's polynomial fit of the Turbo map
 *   ("Turbo, An Improved Rainbow Colormap for Visualization", Google AI
 *   blog, 2019; the 6-term polynomial approximation he published).
 * - ch_colormap_diverging: ColorBrewer RdBu, 11 classes (Brewer, Harrower,
 *   Penn State), interpolated linearly in sRGB; reversed so -1 is blue
 *   (carved) and +1 is red (raised).
 * - ch_png_write_height: the diverging colour of h/max|h| multiplied by a
 *   Lambert hillshade (light from the upper left, 45 degrees up), as in
 *   cartographic relief shading (Horn 1981, "Hill shading and the
 *   reflectance map"), with central differences instead of Horn's 3x3.
 *
 * libpng reports errors through longjmp; our handlers copy the message and
 * never print. Output goes through ch_atomic_file; no tIME chunk is written,
 * so the same pixels give the same bytes.
 */
#define _POSIX_C_SOURCE 200809L
#include "ch_png.h"

#include <errno.h>
#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ch_file.h"

typedef struct png_msg {
  char text[256];
} png_msg;

static void on_png_error(png_structp png, png_const_charp msg) {
  png_msg *m = png_get_error_ptr(png);
  if (m && !m->text[0]) snprintf(m->text, sizeof m->text, "%s", msg ? msg : "libpng error");
  png_longjmp(png, 1);
}

static void on_png_warning(png_structp png, png_const_charp msg) {
  (void)png; /* warnings (e.g. a bad ancillary chunk) are not our business */
  (void)msg;
}

ch_status ch_png_write(const char *path, int width, int height, int channels,
                       const uint8_t *pixels, ch_error *err) {
  if (!path) return ch_error_set(err, CH_ERR_INPUT, "(png): no output path");
  if (width < 1 || height < 1 || width > CH_IMAGE_MAX_SIDE || height > CH_IMAGE_MAX_SIDE ||
      (channels != 3 && channels != 4) || !pixels)
    return ch_error_set(err, CH_ERR_INPUT, "%s: cannot write a %dx%d PNG with %d channels", path,
                        width, height, channels);
  ch_atomic_file f;
  ch_status st = ch_atomic_open(&f, path, err);
  if (st != CH_OK) return st;

  png_msg msg = {{0}};
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &msg, on_png_error,
                                            on_png_warning);
  png_infop info = png ? png_create_info_struct(png) : NULL;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    ch_atomic_abort(&f);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for the PNG writer", path);
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    /* libpng says "Write Error"; the file knows which */
    return ch_atomic_fail(&f, ch_error_set(err, CH_ERR_IO, "%s: cannot write PNG: %s", path, msg.text), err);
  }
  png_init_io(png, f.fp);
  png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8,
               channels == 4 ? PNG_COLOR_TYPE_RGB_ALPHA : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  size_t stride = (size_t)width * (size_t)channels;
  for (int y = 0; y < height; y++) png_write_row(png, pixels + (size_t)y * stride);
  png_write_end(png, NULL);
  png_destroy_write_struct(&png, &info);
  return ch_atomic_commit(&f, err);
}

ch_status ch_png_write_height16(const char *path, const float *plane, int width, int height, double *scale,
                               ch_error *err) {
  if (!path || !plane || width < 1 || height < 1 || width > CH_IMAGE_MAX_SIDE || height > CH_IMAGE_MAX_SIDE)
    return ch_error_set(err, CH_ERR_INPUT, "%s: cannot write a %dx%d height PNG", path ? path : "(png)", width,
                        height);
  size_t n = (size_t)width * (size_t)height;
  double s = 0.0;
  for (size_t i = 0; i < n; i++)
    if (isfinite(plane[i])) s = fmax(s, fabs((double)plane[i]));
  uint8_t *rows = malloc(2 * n);
  if (!rows) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", path);
  /* 0.5 is h = 0, 0 and 1 are -s and +s: Blender's Displace modifier reads
   * it with midlevel 0.5 and strength 2s. Big-endian samples (PNG). */
  for (size_t i = 0; i < n; i++) {
    double x = s > 0.0 && isfinite(plane[i]) ? 0.5 + 0.5 * plane[i] / s : 0.5;
    long q = lround(65535.0 * (x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x));
    rows[2 * i] = (uint8_t)(q >> 8);
    rows[2 * i + 1] = (uint8_t)(q & 255);
  }
  char scale_text[64], note[256];
  snprintf(scale_text, sizeof scale_text, "%.9g", s);
  snprintf(note, sizeof note,
           "h = (value / 65535 - 0.5) * %.9g; Blender Displace: midlevel 0.5, strength %.9g, colour space Non-Color",
           2.0 * s, 2.0 * s);
  ch_atomic_file f;
  ch_status st = ch_atomic_open(&f, path, err);
  if (st != CH_OK) {
    free(rows);
    return st;
  }
  png_msg msg = {{0}};
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &msg, on_png_error, on_png_warning);
  png_infop info = png ? png_create_info_struct(png) : NULL;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    ch_atomic_abort(&f);
    free(rows);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for the PNG writer", path);
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    ch_atomic_abort(&f);
    free(rows);
    return ch_error_set(err, CH_ERR_IO, "%s: cannot write PNG: %s", path, msg.text);
  }
  png_init_io(png, f.fp);
  png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 16, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_text text[2];
  memset(text, 0, sizeof text);
  text[0].compression = PNG_TEXT_COMPRESSION_NONE;
  text[0].key = "chisel:height_scale";
  text[0].text = scale_text;
  text[1].compression = PNG_TEXT_COMPRESSION_NONE;
  text[1].key = "Comment";
  text[1].text = note;
  png_set_text(png, info, text, 2);
  png_write_info(png, info);
  for (int y = 0; y < height; y++) png_write_row(png, rows + (size_t)y * 2 * (size_t)width);
  png_write_end(png, NULL);
  png_destroy_write_struct(&png, &info);
  free(rows);
  if (scale) *scale = s;
  return ch_atomic_commit(&f, err);
}

ch_status ch_png_read(const char *path, int *width, int *height, int *channels,
                      uint8_t **pixels, ch_error *err) {
  *width = *height = *channels = 0;
  *pixels = NULL;
  FILE *fp = fopen(path, "rb");
  if (!fp) return ch_error_set(err, CH_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  unsigned char sig[8];
  if (fread(sig, 1, 8, fp) != 8 || png_sig_cmp(sig, 0, 8) != 0) {
    int bad = ferror(fp);
    fclose(fp);
    if (bad) return ch_error_set(err, CH_ERR_IO, "%s: read error", path);
    return ch_error_set(err, CH_ERR_INPUT, "%s: not a PNG file (bad signature)", path);
  }
  png_msg msg = {{0}};
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &msg, on_png_error,
                                           on_png_warning);
  png_infop info = png ? png_create_info_struct(png) : NULL;
  if (!png || !info) {
    png_destroy_read_struct(&png, &info, NULL);
    fclose(fp);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for the PNG reader", path);
  }
  /* Modified after setjmp and used after longjmp: must be volatile. */
  uint8_t *volatile data = NULL;
  png_bytep *volatile rows = NULL;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, NULL);
    fclose(fp);
    free(rows);
    free(data);
    return ch_error_set(err, CH_ERR_INPUT, "%s: bad PNG: %s", path, msg.text);
  }
  png_init_io(png, fp);
  png_set_sig_bytes(png, 8);
  png_set_user_limits(png, CH_IMAGE_MAX_SIDE, CH_IMAGE_MAX_SIDE);
  png_read_info(png, info);
  png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
  /* Everything to 8-bit RGB or RGBA. */
  png_set_expand(png);      /* palette -> RGB, gray < 8 bits -> 8, tRNS -> alpha */
  png_set_strip_16(png);
  png_set_gray_to_rgb(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  int nc = png_get_channels(png, info);
  size_t rowbytes = png_get_rowbytes(png, info);
  if ((nc != 3 && nc != 4) || rowbytes != (size_t)w * (size_t)nc) {
    snprintf(msg.text, sizeof msg.text, "unsupported pixel layout (%d channels)", nc);
    png_longjmp(png, 1);
  }
  data = malloc((size_t)h * rowbytes);
  rows = malloc((size_t)h * sizeof(png_bytep));
  if (!data || !rows) {
    png_destroy_read_struct(&png, &info, NULL);
    fclose(fp);
    free(rows);
    free(data);
    return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for a %ux%u PNG", path,
                        (unsigned)w, (unsigned)h);
  }
  for (png_uint_32 y = 0; y < h; y++) rows[y] = data + (size_t)y * rowbytes;
  png_read_image(png, rows);
  png_read_end(png, NULL);
  png_destroy_read_struct(&png, &info, NULL);
  fclose(fp);
  free(rows);
  *width = (int)w;
  *height = (int)h;
  *channels = nc;
  *pixels = data;
  return CH_OK;
}

static uint8_t to_byte(double v) {
  if (!(v > 0.0)) return 0; /* also NaN */
  if (v >= 1.0) return 255;
  return (uint8_t)(v * 255.0 + 0.5);
}

void ch_colormap_heat(double x, uint8_t rgb[3]) {
  if (!(x >= 0.0)) x = 0.0; /* also NaN */
  if (x > 1.0) x = 1.0;
  /* Mikhailov's fit: c(x) = sum_{k=0..5} a_k x^k per channel. */
  static const double kr[6] = {0.13572138, 4.61539260, -42.66032258, 132.13108234,
                               -152.94239396, 59.28637943};
  static const double kg[6] = {0.09140261, 2.19418839, 4.84296658, -14.18503333,
                               4.27729857, 2.82956604};
  static const double kb[6] = {0.10667330, 12.64194608, -60.58204836, 110.36276771,
                               -89.90310912, 27.34824973};
  double r = 0, g = 0, b = 0;
  for (int k = 5; k >= 0; k--) { /* Horner */
    r = r * x + kr[k];
    g = g * x + kg[k];
    b = b * x + kb[k];
  }
  rgb[0] = to_byte(r);
  rgb[1] = to_byte(g);
  rgb[2] = to_byte(b);
}

void ch_colormap_diverging(double x, uint8_t rgb[3]) {
  /* RdBu-11 from blue (-1) through near-white (0) to red (+1). */
  static const uint8_t stops[11][3] = {
      {5, 48, 97},    {33, 102, 172}, {67, 147, 195}, {146, 197, 222}, {209, 229, 240},
      {247, 247, 247}, {253, 219, 199}, {244, 165, 130}, {214, 96, 77}, {178, 24, 43},
      {103, 0, 31}};
  if (!(x >= -1.0)) x = (x != x) ? 0.0 : -1.0; /* NaN -> 0 */
  if (x > 1.0) x = 1.0;
  double t = (x + 1.0) * 5.0; /* 0..10 */
  int i = (int)t;
  if (i > 9) i = 9;
  double f = t - i;
  for (int k = 0; k < 3; k++) {
    double v = stops[i][k] + (stops[i + 1][k] - stops[i][k]) * f;
    rgb[k] = (uint8_t)(v + 0.5);
  }
}

/* How steep the shaded surface is: z = RELIEF * h/max|h| in texel units.
 * A full-depth step over one texel gives a central difference of 0.5, i.e.
 * a slope of 2 (63 degrees): clearly lit or shadowed; 1% relief per texel
 * still tilts by 2 degrees. */
#define RELIEF 4.0
/* Light from the upper left, 45 degrees above the horizon. */
#define AMBIENT 0.35

ch_status ch_png_write_height(const char *path, const float *plane, int width, int height,
                              ch_error *err) {
  if (!path) return ch_error_set(err, CH_ERR_INPUT, "(png): no output path");
  if (!plane || width < 1 || height < 1 || width > CH_IMAGE_MAX_SIDE ||
      height > CH_IMAGE_MAX_SIDE)
    return ch_error_set(err, CH_ERR_INPUT, "%s: cannot write a %dx%d height preview", path,
                        width, height);
  size_t n = (size_t)width * (size_t)height;
  double hmax = 0.0;
  for (size_t i = 0; i < n; i++)
    if (isfinite(plane[i]) && fabs(plane[i]) > hmax) hmax = fabs(plane[i]);
  double inv = hmax > 0.0 ? 1.0 / hmax : 0.0;
  uint8_t *rgb = malloc(n * 3);
  if (!rgb) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for the preview", path);

  /* Light direction in (x right, y up, z out of the image). */
  const double lx = -0.5, ly = 0.5, lz = 0.70710678118654752;
#define NORM(x, y) (isfinite(plane[(size_t)(y) * width + (x)]) \
                        ? plane[(size_t)(y) * width + (x)] * inv : 0.0)
  for (int y = 0; y < height; y++) {
    for (int x = 0; x < width; x++) {
      uint8_t *px = rgb + ((size_t)y * width + x) * 3;
      float hv = plane[(size_t)y * width + x];
      if (!isfinite(hv)) { /* magenta flags NaN / Inf */
        px[0] = 255;
        px[1] = 0;
        px[2] = 255;
        continue;
      }
      int xl = x > 0 ? x - 1 : x, xr = x < width - 1 ? x + 1 : x;
      int yt = y > 0 ? y - 1 : y, yb = y < height - 1 ? y + 1 : y;
      double dzdx = xr > xl ? (NORM(xr, y) - NORM(xl, y)) / (xr - xl) : 0.0;
      /* rows grow downwards; "up" is -row */
      double dzdy = yb > yt ? (NORM(x, yt) - NORM(x, yb)) / (yb - yt) : 0.0;
      double nx = -RELIEF * dzdx, ny = -RELIEF * dzdy, nz = 1.0;
      double len = sqrt(nx * nx + ny * ny + nz * nz);
      double lambert = (nx * lx + ny * ly + nz * lz) / len;
      if (lambert < 0.0) lambert = 0.0;
      /* flat ground keeps its colour (shade 1); facing the light brightens */
      double shade = AMBIENT + (1.0 - AMBIENT) * lambert / lz;
      uint8_t c[3];
      ch_colormap_diverging(hv * inv, c);
      for (int k = 0; k < 3; k++) px[k] = to_byte(c[k] / 255.0 * shade);
    }
  }
#undef NORM
  ch_status st = ch_png_write(path, width, height, 3, rgb, err);
  free(rgb);
  return st;
}
