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
# The command line as scripts use it, and SVGs drawn without data- attributes.
if(Python3_FOUND)
  add_test(NAME scripting COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_scripting.sh $<TARGET_FILE:chisel>
    ${CMAKE_CURRENT_SOURCE_DIR} ${PROJECT_SOURCE_DIR}/models ${CMAKE_CURRENT_BINARY_DIR}/scripting_tmp)
endif()
# The outputs in the tools people use next to chisel (OpenEXR's exrheader,
# OpenImageIO's oiiotool, ImageMagick, Blender headless); all of them come
# from scripts/install-deps.sh.
find_program(CHISEL_BLENDER blender)
find_program(CHISEL_OIIOTOOL oiiotool)
find_program(CHISEL_CONVERT convert)
find_program(CHISEL_EXRHEADER exrheader)
if(Python3_FOUND AND CHISEL_BLENDER AND CHISEL_OIIOTOOL AND CHISEL_CONVERT AND CHISEL_EXRHEADER)
  add_test(NAME interop COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_interop.sh $<TARGET_FILE:chisel>
    ${CMAKE_CURRENT_SOURCE_DIR} ${PROJECT_SOURCE_DIR}/models ${CMAKE_CURRENT_BINARY_DIR}/interop_tmp)
  set_tests_properties(interop PROPERTIES TIMEOUT 600)
else()
  message(WARNING "test interop left out: it needs blender, oiiotool, convert and exrheader (scripts/install-deps.sh)")
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
