# The validator (src/validate): the Embree-traced truth against analytic
# cases, a mesh that is the truth, convergence, metrics.
ch_add_test(NAME test_validate SOURCES test_validate.c LIBS chisel_validate OpenMP::OpenMP_C m)
# chisel study end to end (tests/data/study: a mesh that is the truth).
add_test(NAME study COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_study.sh $<TARGET_FILE:chisel>
  ${CMAKE_CURRENT_SOURCE_DIR}/data/study ${PROJECT_SOURCE_DIR}/models ${CMAKE_CURRENT_BINARY_DIR}/study_tmp)
