# Feature-curve textures and the msdf baseline (shade/ch_featmap*, ch_msdf):
# closed-form cases, exact maps against the study's truth normal, fallback,
# threads, the EXR round trip and damaged files.
ch_add_test(NAME test_featmap SOURCES test_featmap.c LIBS chisel_validate OpenMP::OpenMP_C m)
# chisel featmap / magnify end to end (exit statuses, messages, no output on
# failure, thread independence; magnify's values read back by an
# independent EXR reader against a straight groove in closed form).
find_package(Python3 COMPONENTS Interpreter)
add_test(NAME featmap_cli COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_featmap_cli.sh $<TARGET_FILE:chisel>
  ${CMAKE_CURRENT_SOURCE_DIR} ${PROJECT_SOURCE_DIR}/models ${CMAKE_CURRENT_BINARY_DIR}/featmap_cli_tmp
  "$<IF:$<BOOL:${Python3_FOUND}>,${Python3_EXECUTABLE},python3>")
