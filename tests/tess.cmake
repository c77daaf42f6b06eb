# Base surface and tessellation tests (tess/ch_surface). tess_reference.cpp
# is an independent Catmull-Clark evaluation through Far's PatchTable.
ch_add_test(NAME test_tess SOURCES test_tess.c tess_reference.cpp
            LIBS chisel_tess chisel_opensubdiv OpenMP::OpenMP_C)
ch_add_test(NAME test_geomimage SOURCES test_geomimage.c LIBS chisel_tess)
ch_add_test(NAME test_embed SOURCES test_embed.c LIBS chisel_tess chisel_accuracy OpenMP::OpenMP_C m)
ch_add_test(NAME test_thin SOURCES test_thin.c LIBS chisel_tess m)
ch_add_test(NAME test_count SOURCES test_count.c LIBS chisel_tess m)
ch_add_test(NAME test_label SOURCES test_label.c LIBS chisel_tess m)
