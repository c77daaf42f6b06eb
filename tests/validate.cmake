# The validator (src/validate): the Embree-traced truth against analytic
# cases, a mesh that is the truth, convergence, metrics.
ch_add_test(NAME test_validate SOURCES test_validate.c LIBS chisel_validate OpenMP::OpenMP_C m)
