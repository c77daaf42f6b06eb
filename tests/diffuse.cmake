# ch_diffuse: the solver against an independent direct solve (CHOLMOD, from
# SuiteSparse: Debian libsuitesparse-dev) plus exact cases. Without CHOLMOD
# the direct comparison is skipped with a message; the rest still runs.
ch_add_test(NAME test_diffuse SOURCES test_diffuse.c LIBS chisel_shade OpenMP::OpenMP_C m)
find_path(CHISEL_CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHISEL_CHOLMOD_LIBRARY cholmod)
if(CHISEL_CHOLMOD_INCLUDE_DIR AND CHISEL_CHOLMOD_LIBRARY)
  target_include_directories(test_diffuse PRIVATE ${CHISEL_CHOLMOD_INCLUDE_DIR})
  target_link_libraries(test_diffuse PRIVATE ${CHISEL_CHOLMOD_LIBRARY})
  target_compile_definitions(test_diffuse PRIVATE CHISEL_HAVE_CHOLMOD=1)
else()
  message(STATUS "CHOLMOD not found (libsuitesparse-dev): test_diffuse skips the direct-solve comparison")
endif()
set_tests_properties(test_diffuse PROPERTIES TIMEOUT 300)
