# The validator (src/validate): the Embree-traced truth against analytic
# cases, a mesh that is the truth, convergence, metrics.
ch_add_test(NAME test_validate SOURCES test_validate.c LIBS chisel_validate OpenMP::OpenMP_C m)
# chisel study end to end (tests/data/study: a mesh that is the truth).
add_test(NAME study COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_study.sh $<TARGET_FILE:chisel>
  ${CMAKE_CURRENT_SOURCE_DIR}/data/study ${PROJECT_SOURCE_DIR}/models ${CMAKE_CURRENT_BINARY_DIR}/study_tmp)
# The validator's public headers compile on their own from C and C++ (as
# headers.cmake checks the other folders').
file(GLOB CHISEL_VALIDATE_HEADERS ${PROJECT_SOURCE_DIR}/src/validate/*.h)
set(validate_includes "")
foreach(h ${CHISEL_VALIDATE_HEADERS})
  string(APPEND validate_includes "#include \"${h}\"\n")
endforeach()
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/validate_headers_c.c "${validate_includes}int main(void) { return 0; }\n")
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/validate_headers_cpp.cpp "${validate_includes}int main() { return 0; }\n")
add_executable(test_validate_headers_c ${CMAKE_CURRENT_BINARY_DIR}/validate_headers_c.c)
add_executable(test_validate_headers_cpp ${CMAKE_CURRENT_BINARY_DIR}/validate_headers_cpp.cpp)
foreach(t test_validate_headers_c test_validate_headers_cpp)
  target_include_directories(${t} PRIVATE ${PROJECT_SOURCE_DIR}/src/core ${PROJECT_SOURCE_DIR}/mesh
    ${PROJECT_SOURCE_DIR}/shade ${PROJECT_SOURCE_DIR}/src/validate)
  target_compile_options(${t} PRIVATE -Werror)
  add_test(NAME ${t} COMMAND ${t})
endforeach()
# Path-based groove textures (shade/ch_gtex) against the groove field and
# the Embree-traced truth; relief mapping and POM (shade/ch_relief).
ch_add_test(NAME test_gtex SOURCES test_gtex.c LIBS chisel_validate OpenMP::OpenMP_C m)
ch_add_test(NAME test_relief SOURCES test_relief.c LIBS chisel_shade OpenMP::OpenMP_C m)
# The study's scene file (ch_scene): values parsed, every error naming the key.
ch_add_test(NAME test_scene SOURCES test_scene.c LIBS chisel_validate OpenMP::OpenMP_C m)
# The study as a library call (ch_study, ch_report) on the bundled box groove.
ch_add_test(NAME test_study_lib SOURCES test_study_lib.c LIBS chisel_validate OpenMP::OpenMP_C m)
