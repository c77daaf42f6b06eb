/* 8SSEDT (Danielsson 1980; Leymarie and Levine's vector form): two raster
 * passes, each sample taking the nearer of its own and its neighbours'
 * seeds' points. Exact samples keep theirs. */
#include "ch_edt.h"

#include <stddef.h>

static inline void relax(ch_edt_rec *r, const ch_edt_rec *n, float x, float y) {
  if (n->seed < 0) return;
  float ox = n->x - x, oy = n->y - y, d2 = ox * ox + oy * oy;
  if (d2 < r->d2) *r = (ch_edt_rec){n->x, n->y, d2, n->seed};
}

void ch_edt_propagate(ch_edt_rec *p, const uint8_t *exact, int W, int H) {
  for (int y = 0; y < H; y++) {
    ch_edt_rec *row = p + (size_t)y * W, *dn = y > 0 ? row - W : NULL;
    const uint8_t *ex = exact + (size_t)y * W;
    for (int x = 0; x < W; x++) {
      if (ex[x]) continue;
      if (x > 0) relax(&row[x], &row[x - 1], (float)x, (float)y);
      if (dn) {
        if (x > 0) relax(&row[x], &dn[x - 1], (float)x, (float)y);
        relax(&row[x], &dn[x], (float)x, (float)y);
        if (x + 1 < W) relax(&row[x], &dn[x + 1], (float)x, (float)y);
      }
    }
    for (int x = W - 2; x >= 0; x--)
      if (!ex[x]) relax(&row[x], &row[x + 1], (float)x, (float)y);
  }
  for (int y = H - 1; y >= 0; y--) {
    ch_edt_rec *row = p + (size_t)y * W, *up = y + 1 < H ? row + W : NULL;
    const uint8_t *ex = exact + (size_t)y * W;
    for (int x = W - 1; x >= 0; x--) {
      if (ex[x]) continue;
      if (x + 1 < W) relax(&row[x], &row[x + 1], (float)x, (float)y);
      if (up) {
        if (x + 1 < W) relax(&row[x], &up[x + 1], (float)x, (float)y);
        relax(&row[x], &up[x], (float)x, (float)y);
        if (x > 0) relax(&row[x], &up[x - 1], (float)x, (float)y);
      }
    }
    for (int x = 1; x < W; x++)
      if (!ex[x]) relax(&row[x], &row[x - 1], (float)x, (float)y);
  }
}
