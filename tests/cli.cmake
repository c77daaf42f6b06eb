# The command line end to end: exit codes, messages, outputs.
add_test(NAME cli COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_cli.sh $<TARGET_FILE:chisel>
  ${CMAKE_CURRENT_SOURCE_DIR} ${PROJECT_SOURCE_DIR}/models ${CMAKE_CURRENT_BINARY_DIR}/cli_tmp)
# chisel sample against an independent Python implementation of SPEC §3.
find_package(Python3 COMPONENTS Interpreter)
if(Python3_FOUND)
  add_test(NAME sample_vs_reference COMMAND ${Python3_EXECUTABLE}
    ${CMAKE_CURRENT_SOURCE_DIR}/tools/check_sample.py $<TARGET_FILE:chisel>
    ${CMAKE_CURRENT_BINARY_DIR}/sample_ref --files 12 --res 40)
endif()
# Faults: outputs that are inputs or not plain files, a full disk for every
# format, SIGINT/SIGTERM/SIGKILL while writing (tests/test_faults.sh).
add_test(NAME faults COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_faults.sh $<TARGET_FILE:chisel>
  ${PROJECT_SOURCE_DIR}/models ${CMAKE_CURRENT_SOURCE_DIR} ${CMAKE_CURRENT_BINARY_DIR}/faults_tmp)
# Pathological curve sets at a CI size (tests/test_pathological.sh).
if(Python3_FOUND)
  add_test(NAME pathological COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_pathological.sh $<TARGET_FILE:chisel>
    ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_BINARY_DIR}/pathological_tmp)
endif()
