ch_add_test(NAME test_geometry SOURCES test_geometry.c LIBS chisel_shade)
ch_add_test(NAME test_svg SOURCES test_svg.c LIBS chisel_shade)
ch_add_test(NAME test_dci SOURCES test_dci.c LIBS chisel_shade)
ch_add_test(NAME test_warp SOURCES test_warp.c LIBS chisel_shade)
