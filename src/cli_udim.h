/* UDIM tiles for `chisel displace` (cli_udim.c): the tiles a base mesh's
 * UVs span, the curve file of each tile, and the atlas of the UV square the
 * pipeline runs on. Not thread-safe (plain data); no output of its own. */
#ifndef CH_CLI_UDIM_H
#define CH_CLI_UDIM_H

#include <stddef.h>

#include "ch_curves.h"
#include "ch_error.h"
#include "ch_mesh.h"
#include "cli.h"

enum { CLI_UDIM_MAX_TILES = 100 };

typedef struct cli_udim {
  int num_tiles;
  int tiles[CLI_UDIM_MAX_TILES];       /* tile numbers (1001 + u + 10 v), ascending */
  int grid;                            /* the atlas: grid x grid cells over the UV square */
  double scale, margin;                /* tile UV -> atlas: origin + uv * scale */
  double origin[CLI_UDIM_MAX_TILES][2];
} cli_udim;

/* The tiles the faces of mesh lie in (each face in one tile, its corners
 * within it to 1e-9; else CH_ERR_INPUT naming the face). A mesh without
 * UVs gives no tiles. */
ch_status cli_udim_tiles(const ch_mesh *mesh, const char *name, cli_udim *u, ch_error *err);

/* The curve file of a tile from the CURVES argument: a `<UDIM>` token
 * (Blender's) is replaced by the tile's number; NAME.1001.svg or
 * NAME_1001.svg have their number replaced; NAME.svg gives NAME.TILE.svg
 * (variant 0) or NAME_TILE.svg (variant 1). Returns 0 when there is no such
 * variant (or out is too small). */
int cli_udim_curve_path(const char *arg, int tile, char *out, size_t size, int variant);

/* The largest reach of the curves beyond their lines, in their UV: half a
 * groove's width, three blur radii of a step. */
double cli_udim_reach(const ch_curve_set *set);

/* Whether some step curve is open or has a value on its right (outside),
 * so that diffusing the atlas as one image could carry it across tiles. */
int cli_udim_open_steps(const ch_curve_set *set);

/* Lays the tiles out in the atlas, margins wider than reach (tile UV). */
void cli_udim_layout(cli_udim *u, double reach);

/* Maps the mesh's UVs into the atlas (a UV value shared by faces of two
 * tiles becomes one per tile). */
ch_status cli_udim_to_atlas(ch_mesh *mesh, const cli_udim *u, ch_error *err);

/* Maps UVs of the atlas back to the tiles (each by the cell it lies in). */
void cli_udim_from_atlas(ch_mesh *mesh, const cli_udim *u);

/* One curve set of the atlas from each tile's (sets[k] for u->tiles[k]). */
ch_status cli_udim_merge(const ch_curve_set *sets, const cli_udim *u, ch_curve_set *out, ch_error *err);

/* cli_check_files for `chisel displace`, with every existing file that
 * would be a UDIM tile's curves for the CURVES argument curves (any tile,
 * either spelling, see cli_udim_curve_path) counted as an input too: which
 * tiles the mesh spans is known only after reading it, and no output may
 * replace a tile's file. Prints one line and returns 2 (1: out of memory)
 * on a problem; otherwise 0. */
int cli_udim_check_files(const char *cmd, const cli_file *inputs, int num_inputs, const char *curves,
                         const cli_file *outputs, int num_outputs);

#endif
