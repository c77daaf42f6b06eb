/* ch_exr: OpenEXR read/write through the OpenEXRCore C API (v3.1).
 *
 * The only file in chisel that includes OpenEXR. Format reference: "OpenEXR
 * File Layout" (openexr.com/en/latest/OpenEXRFileLayout.html); the API is
 * OpenEXRCore's chunk pipeline (exr_start_read / exr_start_write,
 * exr_{read,write}_*_chunk_info, exr_{de,en}coding_*).
 *
 * Where we depart from the library defaults, and why:
 * - I/O goes through our own read/write callbacks (pread on a file, a memory
 *   buffer, or the FILE* of a ch_atomic_file), so the output appears only
 *   complete and the same reader serves files, memory and the fuzz target.
 * - OpenEXRCore's default error handler prints to stderr; ours stores the
 *   first message of the failing call so it becomes our one-line message.
 * - Decoding uses our own unpack routine (after the library has read and
 *   decompressed a chunk): it converts half/float/uint to float in one place
 *   and does not depend on the library's specialised 3/4-channel unpackers
 *   (3.1.5 gets them right, but an upstream snapshot of unpack.c has
 *   `in2 = in1 + 1` instead of `in1 + w` in its 3-channel planar ones).
 *   Uncompressed all-float files still take the library's direct-read
 *   path, which copies straight into our planes.
 * - B44/B44A chunks stored raw are copied (see decompress_or_copy), and the
 *   pipeline buffers are zero-filled (see zeroed_alloc).
 * - Before any pixel data is read, the header is checked against the size of
 *   the input (offset table present, plausible compression ratio), so a tiny
 *   or hostile file cannot make us allocate gigabytes.
 *
 * Limits: the first part only; no deep or subsampled images; DWAA/DWAB
 * files fail cleanly with OpenEXRCore 3.1 ("DWA/A decompression not yet
 * implemented in C"), newer releases decode them.
 */
#define _POSIX_C_SOURCE 200809L
#include "ch_exr.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include <omp.h>
#include <openexr.h>

#include "ch_file.h"

/* Decoded float bytes allowed per input byte for compressed files. zlib
 * peaks near 1032:1 and RLE at 64:1; PIZ and DWA on constant data can go
 * further, so this is generous. Uncompressed files must hold every byte. */
enum { MAX_EXPANSION = 65536 };

/* ------------------------------------------------------------------------ */
/* I/O state shared with the OpenEXRCore callbacks (through user_data).     */

typedef struct io_state {
  const char *name;           /* file name for messages */
  const unsigned char *data;  /* memory source, or NULL */
  int fd;                     /* file source, or -1 */
  uint64_t size;              /* bytes available to read */
  FILE *out;                  /* write target (atomic temp file) */
  int os_errno;               /* first errno seen by a read/write callback */
  char message[512];          /* first OpenEXRCore message of the current call */
  int have_message;
} io_state;

static void io_init(io_state *io, const char *name) {
  memset(io, 0, sizeof *io);
  io->name = name ? name : "(exr)";
  io->fd = -1;
}

static void io_reset_message(io_state *io) {
  io->have_message = 0;
  io->message[0] = '\0';
}

/* OpenEXRCore's messages become part of ours: keep the first one of a call
 * (later ones tend to be generic wrappers), on one line. */
static void on_exr_error(exr_const_context_t ctxt, exr_result_t code, const char *msg) {
  void *ud = NULL;
  if (!ctxt || exr_get_user_data(ctxt, &ud) != EXR_ERR_SUCCESS || !ud) return;
  io_state *io = ud;
  if (io->have_message) return;
  if (!msg || !*msg) msg = exr_get_default_error_message(code);
  size_t n = 0;
  for (const char *p = msg; *p && n + 1 < sizeof io->message; p++) {
    unsigned char ch = (unsigned char)*p;
    /* raw bytes from the file end up in these messages: keep ASCII */
    io->message[n++] = (ch < 32 || ch >= 127) ? (ch < 32 ? ' ' : '?') : (char)ch;
  }
  while (n > 0 && io->message[n - 1] == ' ') n--;
  io->message[n] = '\0';
  io->have_message = n > 0;
}

static int64_t read_cb(exr_const_context_t ctxt, void *ud, void *buffer, uint64_t sz,
                       uint64_t offset, exr_stream_error_func_ptr_t error_cb) {
  (void)ctxt;
  (void)error_cb;
  io_state *io = ud;
  if (offset >= io->size || sz == 0) return 0;
  uint64_t n = io->size - offset;
  if (n > sz) n = sz;
  if (n > (uint64_t)INT64_MAX) n = (uint64_t)INT64_MAX;
  if (io->data) {
    memcpy(buffer, io->data + offset, (size_t)n);
    return (int64_t)n;
  }
  uint64_t done = 0;
  while (done < n) {
    size_t want = (size_t)((n - done) > (1u << 30) ? (1u << 30) : (n - done));
    ssize_t got = pread(io->fd, (char *)buffer + done, want, (off_t)(offset + done));
    if (got < 0) {
      if (errno == EINTR) continue;
      if (!io->os_errno) io->os_errno = errno;
      return -1;
    }
    if (got == 0) break;
    done += (uint64_t)got;
  }
  return (int64_t)done;
}

static int64_t size_cb(exr_const_context_t ctxt, void *ud) {
  (void)ctxt;
  io_state *io = ud;
  return (int64_t)io->size;
}

/* pwrite semantics on a stdio stream: OpenEXRCore writes the header, leaves
 * room for the offset table, writes the chunks and goes back to fill the
 * table in exr_finish. */
static int64_t write_cb(exr_const_context_t ctxt, void *ud, const void *buffer, uint64_t sz,
                        uint64_t offset, exr_stream_error_func_ptr_t error_cb) {
  (void)ctxt;
  (void)error_cb;
  io_state *io = ud;
  if (offset > (uint64_t)INT64_MAX || sz > (uint64_t)INT64_MAX) return -1;
  if (ftello(io->out) != (off_t)offset && fseeko(io->out, (off_t)offset, SEEK_SET) != 0) {
    if (!io->os_errno) io->os_errno = errno ? errno : EIO;
    return -1;
  }
  size_t put = fwrite(buffer, 1, (size_t)sz, io->out);
  if (put != (size_t)sz) {
    if (!io->os_errno) io->os_errno = errno ? errno : EIO;
    return -1;
  }
  return (int64_t)sz;
}

static exr_context_initializer_t make_initializer(io_state *io) {
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = on_exr_error;
  init.user_data = io;
  if (io->out) {
    init.write_fn = write_cb;
  } else {
    init.read_fn = read_cb;
    init.size_fn = size_cb;
    init.max_image_width = CH_IMAGE_MAX_SIDE;
    init.max_image_height = CH_IMAGE_MAX_SIDE;
    init.max_tile_width = CH_IMAGE_MAX_SIDE;
    init.max_tile_height = CH_IMAGE_MAX_SIDE;
    /* A damaged offset table is an error, not a reason to scan the file. */
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
  }
  return init;
}

/* Sets err for a failed OpenEXRCore call: "name: what: library message". */
static ch_status exr_fail(io_state *io, ch_error *err, exr_result_t rv, ch_status fallback,
                          const char *what) {
  ch_status st = fallback;
  /* While reading, OpenEXRCore 3.1 also returns EXR_ERR_OUT_OF_MEMORY for
   * corrupt data (its B44 decoder does, for a chunk too short for its
   * blocks), and our buffers are bounded by the size checks: so that code
   * is trusted only when writing. */
  if (rv == EXR_ERR_OUT_OF_MEMORY && fallback != CH_ERR_INPUT) st = CH_ERR_NOMEM;
  else if (io->os_errno) st = CH_ERR_IO;
  const char *detail = io->have_message ? io->message : exr_get_default_error_message(rv);
  if (io->os_errno && !io->have_message) detail = strerror(io->os_errno);
  if (io->os_errno && io->have_message)
    return ch_error_set(err, st, "%s: %s: %s (%s)", io->name, what, detail,
                        strerror(io->os_errno));
  return ch_error_set(err, st, "%s: %s: %s", io->name, what, detail);
}

/* ------------------------------------------------------------------------ */
/* Reading                                                                  */

static float half_to_float(uint16_t h) {
  uint32_t sign = (uint32_t)(h & 0x8000u) << 16;
  uint32_t e = (h >> 10) & 0x1fu, m = h & 0x3ffu, bits;
  if (e == 0) {
    if (m == 0) {
      bits = sign;
    } else { /* subnormal: m * 2^-24, exact in float */
      float f = (float)m * (1.0f / 16777216.0f);
      return sign ? -f : f;
    }
  } else if (e == 31) {
    bits = sign | 0x7f800000u | (m << 13);
  } else {
    bits = sign | ((e + 112u) << 23) | (m << 13);
  }
  float f;
  memcpy(&f, &bits, sizeof f);
  return f;
}

static uint32_t load32le(const uint8_t *p) {
  return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

/* Unpacks one decompressed chunk: per line, per channel (file order), width
 * little-endian samples; converts to float into decode_to_ptr (+ line stride). */
static exr_result_t unpack_to_float(exr_decode_pipeline_t *d) {
  const uint8_t *src = d->unpacked_buffer;
  uint64_t need = 0;
  for (int c = 0; c < d->channel_count; c++) {
    const exr_coding_channel_info_t *ch = &d->channels[c];
    if (ch->height != d->chunk.height || ch->width != d->chunk.width || !ch->decode_to_ptr)
      return EXR_ERR_INVALID_ARGUMENT;
    need += (uint64_t)ch->height * (uint64_t)ch->width * (uint64_t)ch->bytes_per_element;
  }
  if (need == 0) return EXR_ERR_SUCCESS;
  if (!src || need > d->chunk.unpacked_size) return EXR_ERR_CORRUPT_CHUNK;
  for (int y = 0; y < d->chunk.height; y++) {
    for (int c = 0; c < d->channel_count; c++) {
      const exr_coding_channel_info_t *ch = &d->channels[c];
      float *dst = (float *)(ch->decode_to_ptr + (size_t)y * (size_t)ch->user_line_stride);
      int w = ch->width;
      switch (ch->data_type) {
      case EXR_PIXEL_HALF:
        for (int x = 0; x < w; x++, src += 2)
          dst[x] = half_to_float((uint16_t)(src[0] | (src[1] << 8)));
        break;
      case EXR_PIXEL_FLOAT:
        for (int x = 0; x < w; x++, src += 4) {
          uint32_t bits = load32le(src);
          memcpy(&dst[x], &bits, sizeof bits);
        }
        break;
      case EXR_PIXEL_UINT:
        for (int x = 0; x < w; x++, src += 4) dst[x] = (float)load32le(src);
        break;
      default: return EXR_ERR_INVALID_ARGUMENT;
      }
    }
  }
  return EXR_ERR_SUCCESS;
}

/* The pipeline's packed, unpacked and scratch buffers come from here, zero
 * filled: if a decompressor leaves part of a buffer unwritten for a corrupt
 * chunk (later OpenEXR releases fixed such cases, e.g. short PXR24 zlib
 * output), we read zeros or this file's own earlier data, never old heap. */
static void *zeroed_alloc(exr_transcoding_pipeline_buffer_id_t id, size_t n) {
  (void)id;
  return calloc(1, n ? n : 1);
}
static void plain_free(exr_transcoding_pipeline_buffer_id_t id, void *p) {
  (void)id;
  free(p);
}

typedef struct decode_hooks {
  exr_result_t (*decompress)(exr_decode_pipeline_t *); /* the library's choice */
} decode_hooks;

/* Writers store a chunk uncompressed when compressing does not make it
 * smaller, for every compression method. OpenEXRCore 3.1.5 honours that
 * except for B44/B44A, whose decoder then fails ("Unable to decompress
 * image data 24 -> 24", e.g. on small edge tiles written by exrmaketiled);
 * treat equal sizes as raw data for every method. */
static exr_result_t decompress_or_copy(exr_decode_pipeline_t *d) {
  const decode_hooks *h = d->decoding_user_data;
  if (d->chunk.packed_size == d->chunk.unpacked_size) {
    if (d->unpacked_buffer != d->packed_buffer && d->chunk.unpacked_size > 0) {
      if (!d->unpacked_buffer || !d->packed_buffer) return EXR_ERR_CORRUPT_CHUNK;
      memcpy(d->unpacked_buffer, d->packed_buffer, (size_t)d->chunk.unpacked_size);
    }
    return EXR_ERR_SUCCESS;
  }
  return h && h->decompress ? h->decompress(d) : EXR_ERR_INVALID_ARGUMENT;
}

/* Decodes one chunk whose top-left texel is (x0, y0) in image coordinates. */
static ch_status decode_chunk(exr_context_t ctx, io_state *io, const exr_chunk_info_t *ci,
                              int x0, int y0, ch_image *img, exr_decode_pipeline_t *dec,
                              decode_hooks *hooks, int *initialized, ch_error *err) {
  char what[96];
  if (ci->width < 1 || ci->height < 1 || x0 < 0 || y0 < 0 || ci->width > img->width - x0 ||
      ci->height > img->height - y0) {
    return ch_error_set(err, CH_ERR_INPUT,
                        "%s: chunk %d covers %dx%d texels at (%d,%d), outside the %dx%d image",
                        io->name, ci->idx, ci->width, ci->height, x0, y0, img->width,
                        img->height);
  }
  if (ci->compression == EXR_COMPRESSION_NONE && ci->packed_size != ci->unpacked_size)
    return ch_error_set(err, CH_ERR_INPUT,
                        "%s: uncompressed chunk %d holds %llu bytes instead of %llu", io->name,
                        ci->idx, (unsigned long long)ci->packed_size,
                        (unsigned long long)ci->unpacked_size);
  snprintf(what, sizeof what, "cannot decode chunk %d (texels %d..%d of rows %d..%d)", ci->idx,
           x0, x0 + ci->width - 1, y0, y0 + ci->height - 1);
  io_reset_message(io);
  exr_result_t rv = *initialized ? exr_decoding_update(ctx, 0, ci, dec)
                                 : exr_decoding_initialize(ctx, 0, ci, dec);
  if (rv != EXR_ERR_SUCCESS) return exr_fail(io, err, rv, CH_ERR_INPUT, what);
  if (!*initialized) { /* exr_decoding_initialize cleared the struct */
    dec->alloc_fn = zeroed_alloc;
    dec->free_fn = plain_free;
    dec->decoding_user_data = hooks;
  }
  for (int k = 0; k < dec->channel_count; k++) {
    exr_coding_channel_info_t *ch = &dec->channels[k];
    int c = ch->channel_name ? ch_image_find(img, ch->channel_name) : -1;
    if (c < 0 || ch->x_samples != 1 || ch->y_samples != 1)
      return ch_error_set(err, CH_ERR_INPUT, "%s: unexpected channel layout in chunk %d",
                          io->name, ci->idx);
    float *plane = ch_image_plane(img, c);
    ch->decode_to_ptr = (uint8_t *)(plane + (size_t)y0 * (size_t)img->width + (size_t)x0);
    ch->user_pixel_stride = (int32_t)sizeof(float);
    ch->user_line_stride = (int32_t)(sizeof(float) * (size_t)img->width);
    ch->user_data_type = EXR_PIXEL_FLOAT;
    ch->user_bytes_per_element = (int16_t)sizeof(float);
  }
  if (!*initialized) {
    rv = exr_decoding_choose_default_routines(ctx, 0, dec);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(io, err, rv, CH_ERR_INPUT, what);
    /* NULL means the library reads uncompressed float data straight into
     * our planes; otherwise unpack with our own routine. */
    if (dec->unpack_and_convert_fn) dec->unpack_and_convert_fn = unpack_to_float;
    if (dec->decompress_fn) {
      hooks->decompress = dec->decompress_fn;
      dec->decompress_fn = decompress_or_copy;
    }
    *initialized = 1;
  }
  rv = exr_decoding_run(ctx, 0, dec);
  if (rv != EXR_ERR_SUCCESS) return exr_fail(io, err, rv, CH_ERR_INPUT, what);
  return CH_OK;
}

static ch_status open_read(io_state *io, exr_context_t *ctx, ch_error *err) {
  static const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
  unsigned char head[4] = {0, 0, 0, 0};
  *ctx = NULL;
  if (io->size == 0) return ch_error_set(err, CH_ERR_INPUT, "%s: empty file", io->name);
  if (read_cb(NULL, io, head, 4, 0, NULL) != 4 || memcmp(head, magic, 4) != 0) {
    if (io->os_errno)
      return ch_error_set(err, CH_ERR_IO, "%s: read error: %s", io->name, strerror(io->os_errno));
    return ch_error_set(err, CH_ERR_INPUT, "%s: not an OpenEXR file (bad magic number)",
                        io->name);
  }
  exr_context_initializer_t init = make_initializer(io);
  io_reset_message(io);
  exr_result_t rv = exr_start_read(ctx, io->name, &init);
  if (rv != EXR_ERR_SUCCESS) {
    ch_status st = exr_fail(io, err, rv, CH_ERR_INPUT, "cannot read EXR header");
    if (*ctx) exr_finish(ctx);
    *ctx = NULL;
    return st;
  }
  int parts = 0;
  rv = exr_get_count(*ctx, &parts);
  if (rv != EXR_ERR_SUCCESS || parts < 1) {
    exr_finish(ctx);
    return ch_error_set(err, CH_ERR_INPUT, "%s: EXR file has no parts", io->name);
  }
  return CH_OK;
}

/* Copies a name from a file into buf for a message: control and non-ASCII
 * bytes become '?', so a message stays one printable line. */
static const char *printable(const char *s, char *buf, size_t size) {
  size_t n = 0;
  for (; s && *s && n + 1 < size; s++) {
    unsigned char ch = (unsigned char)*s;
    buf[n++] = (ch < 32 || ch >= 127) ? '?' : (char)ch;
  }
  buf[n] = '\0';
  return buf;
}

static int has_control_bytes(const char *s) {
  for (; *s; s++)
    if ((unsigned char)*s < 32 || (unsigned char)*s == 127) return 1;
  return 0;
}

static ch_status read_image(io_state *io, ch_image *out, ch_error *err) {
  memset(out, 0, sizeof *out);
  exr_context_t ctx;
  ch_status st = open_read(io, &ctx, err);
  if (st != CH_OK) return st;

  exr_storage_t storage;
  exr_attr_box2i_t dw;
  exr_compression_t comp = EXR_COMPRESSION_NONE;
  const exr_attr_chlist_t *chl = NULL;
  int32_t chunks = 0;
  io_reset_message(io);
  exr_result_t rv = exr_get_storage(ctx, 0, &storage);
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_data_window(ctx, 0, &dw);
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_compression(ctx, 0, &comp);
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_channels(ctx, 0, &chl);
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_chunk_count(ctx, 0, &chunks);
  if (rv != EXR_ERR_SUCCESS) {
    st = exr_fail(io, err, rv, CH_ERR_INPUT, "incomplete EXR header");
    goto done;
  }
  if (storage == EXR_STORAGE_DEEP_SCANLINE || storage == EXR_STORAGE_DEEP_TILED) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: deep EXR images are not supported", io->name);
    goto done;
  }
  if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: unknown EXR part type", io->name);
    goto done;
  }
  int64_t w64 = (int64_t)dw.max.x - (int64_t)dw.min.x + 1;
  int64_t h64 = (int64_t)dw.max.y - (int64_t)dw.min.y + 1;
  if (w64 < 1 || h64 < 1 || w64 > CH_IMAGE_MAX_SIDE || h64 > CH_IMAGE_MAX_SIDE) {
    st = ch_error_set(err, CH_ERR_INPUT,
                      "%s: data window (%d,%d)-(%d,%d) gives a size outside 1..%d", io->name,
                      dw.min.x, dw.min.y, dw.max.x, dw.max.y, CH_IMAGE_MAX_SIDE);
    goto done;
  }
  if (!chl || chl->num_channels < 1 || chl->num_channels > CH_IMAGE_MAX_CHANNELS) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: %d channels (1..%d supported)", io->name,
                      chl ? chl->num_channels : 0, CH_IMAGE_MAX_CHANNELS);
    goto done;
  }
  const char *names[CH_IMAGE_MAX_CHANNELS];
  for (int c = 0; c < chl->num_channels; c++) {
    const exr_attr_chlist_entry_t *e = &chl->entries[c];
    const char *nm = e->name.str ? e->name.str : "";
    if (e->name.length < 1 || e->name.length >= CH_IMAGE_NAME_MAX ||
        strlen(nm) != (size_t)e->name.length) {
      st = ch_error_set(err, CH_ERR_INPUT, "%s: channel %d has an empty or too long name "
                        "(limit %d bytes)", io->name, c, CH_IMAGE_NAME_MAX - 1);
      goto done;
    }
    char shown[CH_IMAGE_NAME_MAX];
    if (has_control_bytes(nm)) {
      st = ch_error_set(err, CH_ERR_INPUT, "%s: channel name '%s' has control characters",
                        io->name, printable(nm, shown, sizeof shown));
      goto done;
    }
    if (e->x_sampling != 1 || e->y_sampling != 1) {
      st = ch_error_set(err, CH_ERR_INPUT, "%s: channel '%s' is subsampled (%d,%d), "
                        "not supported", io->name, printable(nm, shown, sizeof shown),
                        e->x_sampling, e->y_sampling);
      goto done;
    }
    if (e->pixel_type != EXR_PIXEL_HALF && e->pixel_type != EXR_PIXEL_FLOAT &&
        e->pixel_type != EXR_PIXEL_UINT) {
      st = ch_error_set(err, CH_ERR_INPUT, "%s: channel '%s' has unknown pixel type %d",
                        io->name, printable(nm, shown, sizeof shown), (int)e->pixel_type);
      goto done;
    }
    for (int k = 0; k < c; k++) {
      if (strcmp(names[k], nm) == 0) {
        st = ch_error_set(err, CH_ERR_INPUT, "%s: duplicate channel name '%s'", io->name,
                          printable(nm, shown, sizeof shown));
        goto done;
      }
    }
    names[c] = nm;
  }
  int W = (int)w64, H = (int)h64, NC = chl->num_channels;

  /* Plausibility against the input size, before allocating anything big:
   * the offset table (8 bytes per chunk) must be in the file; uncompressed
   * pixel data must be there in full; compressed data cannot expand beyond
   * MAX_EXPANSION. */
  uint64_t raw = 0; /* pixel bytes as stored, uncompressed */
  for (int c = 0; c < NC; c++)
    raw += (uint64_t)W * (uint64_t)H * (chl->entries[c].pixel_type == EXR_PIXEL_HALF ? 2u : 4u);
  uint64_t decoded = (uint64_t)W * (uint64_t)H * (uint64_t)NC * sizeof(float);
  if (chunks < 1 || (uint64_t)chunks * 8u > io->size) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: truncated file (%d chunks need an offset "
                      "table of %llu bytes, file has %llu)", io->name, chunks,
                      (unsigned long long)chunks * 8u, (unsigned long long)io->size);
    goto done;
  }
  if ((comp == EXR_COMPRESSION_NONE && raw > io->size) || decoded / MAX_EXPANSION > io->size) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: truncated or implausible file (%dx%d, %d "
                      "channels, in %llu bytes)", io->name, W, H, NC,
                      (unsigned long long)io->size);
    goto done;
  }

  st = ch_image_init(out, W, H, NC, names, err);
  if (st != CH_OK) {
    ch_error_set(err, st, "%s: cannot allocate a %dx%d image with %d channels", io->name, W, H,
                 NC);
    goto done;
  }

  exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
  decode_hooks hooks = {NULL};
  int initialized = 0;
  if (storage == EXR_STORAGE_SCANLINE) {
    int32_t lpc = 0;
    rv = exr_get_scanlines_per_chunk(ctx, 0, &lpc);
    if (rv != EXR_ERR_SUCCESS || lpc < 1) {
      st = exr_fail(io, err, rv ? rv : EXR_ERR_INVALID_ATTR, CH_ERR_INPUT,
                    "cannot get scanlines per chunk");
      goto done_free;
    }
    for (int64_t y = dw.min.y; y <= dw.max.y; y += lpc) {
      exr_chunk_info_t ci;
      io_reset_message(io);
      rv = exr_read_scanline_chunk_info(ctx, 0, (int)y, &ci);
      if (rv != EXR_ERR_SUCCESS) {
        char what[64];
        snprintf(what, sizeof what, "cannot locate scanline %lld", (long long)y);
        st = exr_fail(io, err, rv, CH_ERR_INPUT, what);
        goto done_free;
      }
      int64_t row = (int64_t)ci.start_y - dw.min.y;
      if (ci.start_y > y || row < 0 || ci.width != W) {
        st = ch_error_set(err, CH_ERR_INPUT, "%s: chunk for scanline %lld is inconsistent",
                          io->name, (long long)y);
        goto done_free;
      }
      st = decode_chunk(ctx, io, &ci, 0, (int)row, out, &dec, &hooks, &initialized, err);
      if (st != CH_OK) goto done_free;
    }
  } else {
    uint32_t tw = 0, th = 0;
    exr_tile_level_mode_t lm;
    exr_tile_round_mode_t rm;
    rv = exr_get_tile_descriptor(ctx, 0, &tw, &th, &lm, &rm);
    if (rv != EXR_ERR_SUCCESS || tw < 1 || th < 1) {
      st = exr_fail(io, err, rv ? rv : EXR_ERR_INVALID_ATTR, CH_ERR_INPUT,
                    "bad tile description");
      goto done_free;
    }
    /* Level (0,0) is the full-resolution image for every level mode. */
    int ntx = (int)(((uint64_t)W + tw - 1) / tw), nty = (int)(((uint64_t)H + th - 1) / th);
    for (int ty = 0; ty < nty; ty++) {
      for (int tx = 0; tx < ntx; tx++) {
        exr_chunk_info_t ci;
        io_reset_message(io);
        rv = exr_read_tile_chunk_info(ctx, 0, tx, ty, 0, 0, &ci);
        if (rv != EXR_ERR_SUCCESS) {
          char what[64];
          snprintf(what, sizeof what, "cannot locate tile (%d,%d)", tx, ty);
          st = exr_fail(io, err, rv, CH_ERR_INPUT, what);
          goto done_free;
        }
        st = decode_chunk(ctx, io, &ci, (int)((uint64_t)tx * tw), (int)((uint64_t)ty * th),
                          out, &dec, &hooks, &initialized, err);
        if (st != CH_OK) goto done_free;
      }
    }
  }
  st = CH_OK;
done_free:
  if (initialized || dec.channels) exr_decoding_destroy(ctx, &dec);
  if (st != CH_OK) ch_image_free(out);
done:
  exr_finish(&ctx);
  return st;
}

/* Opens path for pread; the io_state then reads from the descriptor. */
static ch_status open_file(io_state *io, const char *path, ch_error *err) {
  io_init(io, path);
  int fd = open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return ch_error_set(err, CH_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  struct stat sb;
  if (fstat(fd, &sb) != 0 || !S_ISREG(sb.st_mode)) {
    close(fd);
    return ch_error_set(err, CH_ERR_IO, "%s: not a regular file", path);
  }
  io->fd = fd;
  io->size = (uint64_t)sb.st_size;
  return CH_OK;
}

ch_status ch_exr_read(const char *path, ch_image *out, ch_error *err) {
  io_state io;
  memset(out, 0, sizeof *out);
  ch_status st = open_file(&io, path, err);
  if (st != CH_OK) return st;
  st = read_image(&io, out, err);
  close(io.fd);
  return st;
}

ch_status ch_exr_read_memory(const void *data, size_t size, const char *name, ch_image *out,
                             ch_error *err) {
  io_state io;
  io_init(&io, name ? name : "(memory)");
  memset(out, 0, sizeof *out);
  static const unsigned char nothing[1] = {0};
  io.data = data ? data : nothing;
  io.size = data ? size : 0;
  return read_image(&io, out, err);
}

ch_status ch_exr_read_attribute(const char *path, const char *name, char *value,
                                size_t value_size, ch_error *err) {
  io_state io;
  if (value && value_size) value[0] = '\0';
  ch_status st = open_file(&io, path, err);
  if (st != CH_OK) return st;
  exr_context_t ctx;
  st = open_read(&io, &ctx, err);
  if (st == CH_OK) {
    const exr_attribute_t *attr = NULL;
    io_reset_message(&io);
    exr_result_t rv = exr_get_attribute_by_name(ctx, 0, name, &attr);
    if (rv != EXR_ERR_SUCCESS || !attr) {
      st = ch_error_set(err, CH_ERR_INPUT, "%s: no attribute '%s'", path, name);
    } else if (attr->type != EXR_ATTR_STRING || !attr->string) {
      char shown[64];
      st = ch_error_set(err, CH_ERR_INPUT, "%s: attribute '%s' is of type '%s', not a string",
                        path, name, printable(attr->type_name, shown, sizeof shown));
    } else if (value && value_size) {
      size_t n = attr->string->length > 0 ? (size_t)attr->string->length : 0;
      if (n > value_size - 1) n = value_size - 1;
      if (n) memcpy(value, attr->string->str, n);
      value[n] = '\0';
    }
    exr_finish(&ctx);
  }
  close(io.fd);
  return st;
}

/* A string attribute of the first part, copied into a new buffer. */
static ch_status read_attribute_alloc(io_state *io, const char *name, char **value, ch_error *err) {
  *value = NULL;
  exr_context_t ctx;
  ch_status st = open_read(io, &ctx, err);
  if (st != CH_OK) return st;
  const exr_attribute_t *attr = NULL;
  io_reset_message(io);
  exr_result_t rv = exr_get_attribute_by_name(ctx, 0, name, &attr);
  if (rv != EXR_ERR_SUCCESS || !attr) {
    st = ch_error_set(err, CH_ERR_INPUT, "%s: no attribute '%s'", io->name, name);
  } else if (attr->type != EXR_ATTR_STRING || !attr->string) {
    char shown[64];
    st = ch_error_set(err, CH_ERR_INPUT, "%s: attribute '%s' is of type '%s', not a string", io->name, name,
                      printable(attr->type_name, shown, sizeof shown));
  } else {
    size_t n = attr->string->length > 0 ? (size_t)attr->string->length : 0;
    if (!(*value = malloc(n + 1))) {
      st = ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory for attribute '%s'", io->name, name);
    } else {
      if (n) memcpy(*value, attr->string->str, n);
      (*value)[n] = '\0';
    }
  }
  exr_finish(&ctx);
  return st;
}

ch_status ch_exr_read_attribute_alloc(const char *path, const char *name, char **value, ch_error *err) {
  io_state io;
  *value = NULL;
  ch_status st = open_file(&io, path, err);
  if (st != CH_OK) return st;
  st = read_attribute_alloc(&io, name, value, err);
  close(io.fd);
  return st;
}

ch_status ch_exr_read_attribute_memory(const void *data, size_t size, const char *file, const char *name,
                                       char **value, ch_error *err) {
  io_state io;
  io_init(&io, file ? file : "(memory)");
  static const unsigned char nothing[1] = {0};
  io.data = data ? data : nothing;
  io.size = data ? size : 0;
  return read_attribute_alloc(&io, name, value, err);
}

/* ------------------------------------------------------------------------ */
/* Writing                                                                  */

static ch_status check_write_args(const char *path, const ch_image *img,
                                  const ch_exr_write_desc *d, ch_error *err) {
  if (!img || !img->pixels || img->width < 1 || img->height < 1 ||
      img->width > CH_IMAGE_MAX_SIDE || img->height > CH_IMAGE_MAX_SIDE ||
      img->num_channels < 1 || img->num_channels > CH_IMAGE_MAX_CHANNELS)
    return ch_error_set(err, CH_ERR_INPUT, "%s: cannot write an empty or invalid image", path);
  for (int c = 0; c < img->num_channels; c++) {
    size_t n = strnlen(img->names[c], CH_IMAGE_NAME_MAX);
    if (n == 0 || n >= CH_IMAGE_NAME_MAX)
      return ch_error_set(err, CH_ERR_INPUT, "%s: channel %d has an empty or unterminated name",
                          path, c);
    for (int k = 0; k < c; k++)
      if (strcmp(img->names[k], img->names[c]) == 0)
        return ch_error_set(err, CH_ERR_INPUT, "%s: duplicate channel name '%s'", path,
                            img->names[c]);
  }
  if (d->compression != CH_EXR_ZIP && d->compression != CH_EXR_NONE &&
      d->compression != CH_EXR_PIZ)
    return ch_error_set(err, CH_ERR_INPUT, "%s: unknown compression %d", path,
                        (int)d->compression);
  for (int c = 0; c < img->num_channels; c++) {
    ch_exr_type t = d->channel_types ? d->channel_types[c] : d->type;
    if (t != CH_EXR_FLOAT && t != CH_EXR_HALF)
      return ch_error_set(err, CH_ERR_INPUT, "%s: unknown pixel type %d for channel '%s'", path,
                          (int)t, img->names[c]);
  }
  if (d->luminance && (ch_image_find(img, d->luminance) < 0 || ch_image_find(img, "Y") >= 0 ||
                       img->num_channels >= CH_IMAGE_MAX_CHANNELS))
    return ch_error_set(err, CH_ERR_INPUT, "%s: cannot copy channel '%s' to Y", path, d->luminance);
  if (d->num_attributes < 0 || (d->num_attributes > 0 && !d->attributes))
    return ch_error_set(err, CH_ERR_INPUT, "%s: bad attribute list", path);
  for (int i = 0; i < d->num_attributes; i++) {
    const ch_exr_attribute *a = &d->attributes[i];
    if (!a->name || !a->name[0] || strlen(a->name) > 255 || !a->value)
      return ch_error_set(err, CH_ERR_INPUT, "%s: attribute %d has no name or value", path, i);
  }
  return CH_OK;
}

/* A chunk packed and compressed by a pipeline of write_body's, kept for
 * writing in file order. */
typedef struct encoded_chunk {
  void *bytes;
  uint64_t size;
  exr_result_t rv;
} encoded_chunk;

/* The pipeline's wait for its turn to write (yield_until_ready_fn): none,
 * as capture_chunk does not write; the default one fails any chunk but
 * the next in file order. */
static exr_result_t any_order(exr_encode_pipeline_t *e) {
  (void)e;
  return EXR_ERR_SUCCESS;
}

/* The pipeline's write step (openexr_encode.h's write_fn): keeps a copy of
 * what the library's own would write (the compressed buffer: for an
 * uncompressed part, the packed one). */
static exr_result_t capture_chunk(exr_encode_pipeline_t *e) {
  encoded_chunk *o = e->encoding_user_data;
  if (!e->compressed_buffer || e->compressed_bytes == 0) return EXR_ERR_INVALID_ARGUMENT;
  if (!(o->bytes = malloc(e->compressed_bytes))) return EXR_ERR_OUT_OF_MEMORY;
  memcpy(o->bytes, e->compressed_buffer, e->compressed_bytes);
  o->size = e->compressed_bytes;
  return EXR_ERR_SUCCESS;
}

/* Everything between ch_atomic_open and exr_finish; returns the status and
 * leaves *ctx for the caller to finish. */
static ch_status write_body(exr_context_t ctx, io_state *io, const ch_image *img,
                            const ch_exr_write_desc *d, ch_error *err) {
  exr_compression_t comp = d->compression == CH_EXR_NONE  ? EXR_COMPRESSION_NONE
                           : d->compression == CH_EXR_PIZ ? EXR_COMPRESSION_PIZ
                                                          : EXR_COMPRESSION_ZIP;
  int part = 0;
  exr_result_t rv;
  int longnames = 0;
  for (int c = 0; c < img->num_channels; c++)
    if (strlen(img->names[c]) > 31) longnames = 1;
  for (int i = 0; i < d->num_attributes; i++)
    if (strlen(d->attributes[i].name) > 31) longnames = 1;

  io_reset_message(io);
  rv = exr_add_part(ctx, NULL, EXR_STORAGE_SCANLINE, &part);
  if (rv == EXR_ERR_SUCCESS)
    rv = exr_initialize_required_attr_simple(ctx, part, img->width, img->height, comp);
  if (rv == EXR_ERR_SUCCESS && longnames) rv = exr_set_longname_support(ctx, 1);
  if (rv != EXR_ERR_SUCCESS) return exr_fail(io, err, rv, CH_ERR_INTERNAL, "cannot set up header");
  for (int c = 0; c < img->num_channels; c++) {
    ch_exr_type t = d->channel_types ? d->channel_types[c] : d->type;
    io_reset_message(io);
    rv = exr_add_channel(ctx, part, img->names[c],
                         t == CH_EXR_HALF ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                         EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv != EXR_ERR_SUCCESS) {
      char what[128];
      snprintf(what, sizeof what, "cannot add channel '%s'", img->names[c]);
      return exr_fail(io, err, rv, CH_ERR_INPUT, what);
    }
  }
  if (d->luminance) {
    ch_exr_type t = d->channel_types ? d->channel_types[ch_image_find(img, d->luminance)] : d->type;
    io_reset_message(io);
    rv = exr_add_channel(ctx, part, "Y", t == CH_EXR_HALF ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                         EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv != EXR_ERR_SUCCESS) return exr_fail(io, err, rv, CH_ERR_INPUT, "cannot add channel 'Y'");
  }
  for (int i = 0; i < d->num_attributes; i++) {
    io_reset_message(io);
    rv = exr_attr_set_string(ctx, part, d->attributes[i].name, d->attributes[i].value);
    if (rv != EXR_ERR_SUCCESS) {
      char what[320];
      snprintf(what, sizeof what, "cannot set attribute '%s'", d->attributes[i].name);
      return exr_fail(io, err, rv, CH_ERR_INPUT, what);
    }
  }
  io_reset_message(io);
  rv = exr_write_header(ctx);
  if (rv != EXR_ERR_SUCCESS) return exr_fail(io, err, rv, CH_ERR_INTERNAL, "cannot write header");

  int32_t lpc = 0;
  rv = exr_get_scanlines_per_chunk(ctx, part, &lpc);
  if (rv != EXR_ERR_SUCCESS || lpc < 1)
    return exr_fail(io, err, rv ? rv : EXR_ERR_UNKNOWN, CH_ERR_INTERNAL,
                    "cannot get scanlines per chunk");

  /* Y: the luminance channel, mapped when asked (one plane). */
  float *y_plane = NULL;
  int lum = d->luminance ? ch_image_find(img, d->luminance) : -1;
  if (lum >= 0 && d->luminance_scale != 0.0) {
    size_t n = (size_t)img->width * (size_t)img->height;
    y_plane = malloc(n * sizeof *y_plane);
    if (!y_plane) return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", io->name);
    const float *src = ch_image_plane(img, lum);
    for (size_t i = 0; i < n; i++) y_plane[i] = (float)(d->luminance_offset + d->luminance_scale * src[i]);
  }
  /* Chunks are packed and compressed side by side, a batch at a time,
   * each thread with its own pipeline (openexr_encode.h: one per thread,
   * all on one context), their bytes kept by the pipeline's write step
   * (capture_chunk) and then written in file order: the same file as
   * writing them one by one (zlib at 4096^2 x 12 channels was most of
   * the maps' write). */
  int nchunks = (img->height + lpc - 1) / lpc, nthreads = omp_get_max_threads();
  if (nthreads < 1) nthreads = 1;
  /* four chunks a thread, but no more than about 256 MB of them held at
   * once where there are enough threads to fill that */
  double chunk_bytes = (double)lpc * img->width * (img->num_channels + (lum >= 0)) * sizeof(float);
  int batch = (int)fmin(4.0 * nthreads, fmax((double)nthreads, 256e6 / chunk_bytes));
  exr_chunk_info_t *info = malloc((size_t)batch * sizeof *info);
  encoded_chunk *out = calloc((size_t)batch, sizeof *out);
  exr_encode_pipeline_t *enc = calloc((size_t)nthreads, sizeof *enc);
  int *initialized = calloc((size_t)nthreads, sizeof *initialized);
  ch_status st = CH_OK;
  if (!info || !out || !enc || !initialized) st = ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory", io->name);
  for (int c0 = 0; c0 < nchunks && st == CH_OK; c0 += batch) {
    int n = nchunks - c0 < batch ? nchunks - c0 : batch;
    for (int i = 0; i < n; i++) {
      io_reset_message(io);
      rv = exr_write_scanline_chunk_info(ctx, part, (c0 + i) * lpc, &info[i]);
      if (rv != EXR_ERR_SUCCESS) {
        char what[64];
        snprintf(what, sizeof what, "cannot write scanlines from %d", (c0 + i) * lpc);
        st = exr_fail(io, err, rv, CH_ERR_INTERNAL, what);
        break;
      }
    }
    if (st != CH_OK) break;
#pragma omp parallel for schedule(dynamic, 1)
    for (int i = 0; i < n; i++) {
      exr_encode_pipeline_t *e = &enc[omp_get_thread_num()];
      int *ready = &initialized[omp_get_thread_num()];
      int y = (c0 + i) * lpc;
      encoded_chunk *o = &out[i];
      o->rv = *ready ? exr_encoding_update(ctx, part, &info[i], e) : exr_encoding_initialize(ctx, part, &info[i], e);
      if (o->rv != EXR_ERR_SUCCESS) continue;
      int fresh = !*ready;
      *ready = 1;
      for (int k = 0; k < e->channel_count; k++) {
        exr_coding_channel_info_t *ch = &e->channels[k];
        int c = ch->channel_name ? ch_image_find(img, ch->channel_name) : -1;
        int is_y = c < 0 && lum >= 0 && ch->channel_name && !strcmp(ch->channel_name, "Y");
        if (is_y) c = lum;
        if (c < 0) { /* (cannot happen: the channels are the image's) */
          o->rv = EXR_ERR_INVALID_ARGUMENT;
          break;
        }
        ch->encode_from_ptr =
            (const uint8_t *)((is_y && y_plane ? y_plane : ch_image_plane(img, c)) + (size_t)y * (size_t)img->width);
        ch->user_pixel_stride = (int32_t)sizeof(float);
        ch->user_line_stride = (int32_t)(sizeof(float) * (size_t)img->width);
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = (int16_t)sizeof(float);
      }
      if (o->rv != EXR_ERR_SUCCESS) continue;
      if (fresh && (o->rv = exr_encoding_choose_default_routines(ctx, part, e)) != EXR_ERR_SUCCESS) continue;
      e->write_fn = capture_chunk;
      e->yield_until_ready_fn = any_order;
      e->encoding_user_data = o;
      o->rv = exr_encoding_run(ctx, part, e);
    }
    for (int i = 0; i < n && st == CH_OK; i++) {
      char what[64];
      snprintf(what, sizeof what, "cannot write scanlines from %d", (c0 + i) * lpc);
      io_reset_message(io);
      rv = out[i].rv;
      if (rv == EXR_ERR_SUCCESS) rv = exr_write_scanline_chunk(ctx, part, (c0 + i) * lpc, out[i].bytes, out[i].size);
      if (rv != EXR_ERR_SUCCESS) st = exr_fail(io, err, rv, CH_ERR_INTERNAL, what);
    }
    for (int i = 0; i < n; i++) {
      free(out[i].bytes);
      memset(&out[i], 0, sizeof out[i]);
    }
  }
  for (int t = 0; t < nthreads && enc; t++)
    if (initialized && initialized[t]) exr_encoding_destroy(ctx, &enc[t]);
  free(info);
  free(out);
  free(enc);
  free(initialized);
  free(y_plane);
  return st;
}

ch_status ch_exr_write(const char *path, const ch_image *img, const ch_exr_write_desc *desc,
                       ch_error *err) {
  static const ch_exr_write_desc defaults = {0};
  const ch_exr_write_desc *d = desc ? desc : &defaults;
  if (!path) return ch_error_set(err, CH_ERR_INPUT, "(exr): no output path");
  ch_status st = check_write_args(path, img, d, err);
  if (st != CH_OK) return st;

  ch_atomic_file f;
  st = ch_atomic_open(&f, path, err);
  if (st != CH_OK) return st;

  io_state io;
  io_init(&io, path);
  io.out = f.fp;
  exr_context_initializer_t init = make_initializer(&io);
  exr_context_t ctx = NULL;
  io_reset_message(&io);
  exr_result_t rv = exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init);
  if (rv != EXR_ERR_SUCCESS) {
    st = exr_fail(&io, err, rv, CH_ERR_INTERNAL, "cannot start writing");
    if (ctx) exr_finish(&ctx);
    return ch_atomic_fail(&f, st, err);
  }
  st = write_body(ctx, &io, img, d, err);
  io_reset_message(&io);
  rv = exr_finish(&ctx); /* writes the offset table */
  if (st == CH_OK && rv != EXR_ERR_SUCCESS)
    st = exr_fail(&io, err, rv, CH_ERR_INTERNAL, "cannot finish file");
  if (st == CH_OK && io.os_errno) st = ch_file_error(err, path, "cannot write", io.os_errno);
  if (st != CH_OK) return ch_atomic_fail(&f, st, err); /* a failed write names its errno */
  return ch_atomic_commit(&f, err);
}
