/* chisel.h: every public header of the chisel libraries, in the order the
 * data flows through them (docs/architecture.md). Installed as
 * <chisel/chisel.h>; link chisel::chisel (CMake) or `pkg-config --libs
 * chisel`. A program may also include single headers (<chisel/ch_curves.h>)
 * and link only the libraries it needs (chisel::core, chisel::mesh,
 * chisel::shade, chisel::tess, chisel::validate). */
#ifndef CHISEL_H
#define CHISEL_H

/* src/core: version, errors, files, images, EXR and PNG, math */
#include "ch_version.h"
#include "ch_error.h"
#include "ch_alloc.h"
#include "ch_sort.h"
#include "ch_file.h"
#include "ch_progress.h"
#include "ch_image.h"
#include "ch_exr.h"
#include "ch_png.h"
#include "ch_math.h"
#include "ch_camera.h"

/* mesh/: the base mesh, its readers, validation and writers */
#include "ch_mesh.h"
#include "ch_mesh_scan.h"

/* shade/: curves and their exact geometry, the DCI, h, the warp */
#include "ch_bezier.h"
#include "ch_css.h"
#include "ch_curves.h"
#include "ch_dci.h"
#include "ch_diffuse.h"
#include "ch_fillunion.h"
#include "ch_grid.h"
#include "ch_groove.h"
#include "ch_height.h"
#include "ch_recon.h"
#include "ch_samples.h"
#include "ch_segtree.h"
#include "ch_warp.h"
#include "ch_warp_curves.h"

/* shade/: texture-space methods, each built once and evaluated per pixel */
#include "ch_gtex.h"
#include "ch_relief.h"
#include "ch_edt.h"
#include "ch_featmap_cell.h"
#include "ch_featmap.h"
#include "ch_msdf.h"
#include "ch_stepsing.h"
#include "ch_dlayer.h"

/* tess/: the base surface (OpenSubdiv), geometry images, displacement and
 * the feature embedding */
#include "ch_surface.h"
#include "ch_tess.h"
#include "ch_geomimage.h"
#include "ch_displace.h"
#include "ch_count.h"
#include "ch_embed.h"
#include "ch_thin.h"

/* src/pipeline: one call per job (displace), and UDIM tiles */
#include "ch_udim.h"
#include "ch_pipeline.h"

/* src/validate: the Embree truth, traces, renders and metrics, the study's
 * scene file, its run and reports */
#include "ch_truth.h"
#include "ch_trace.h"
#include "ch_render.h"
#include "ch_metrics.h"
#include "ch_texray.h"
#include "ch_featshade.h"
#include "ch_scene.h"
#include "ch_report.h"
#include "ch_study.h"

#endif
