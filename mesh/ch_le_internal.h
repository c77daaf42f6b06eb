/* Little-endian 32-bit words and floats into a byte buffer, for the binary
 * writers (PLY, glTF): each returns the byte after what it wrote. Not
 * installed. */
#ifndef CH_LE_INTERNAL_H
#define CH_LE_INTERNAL_H

#include <stdint.h>
#include <string.h>

static inline unsigned char *ch_le_u32(unsigned char *o, uint32_t u) {
  o[0] = (unsigned char)u;
  o[1] = (unsigned char)(u >> 8);
  o[2] = (unsigned char)(u >> 16);
  o[3] = (unsigned char)(u >> 24);
  return o + 4;
}

/* x rounded to the nearest float. */
static inline unsigned char *ch_le_f32(unsigned char *o, double x) {
  float f = (float)x;
  uint32_t u;
  memcpy(&u, &f, 4);
  return ch_le_u32(o, u);
}

#endif
