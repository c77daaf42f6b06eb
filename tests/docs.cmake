# The documentation against the program: docs/cli.md names every command and
# every option the CLI accepts (tests/test_docs_cli.sh).
add_test(NAME docs_cli COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_docs_cli.sh $<TARGET_FILE:chisel>
  ${PROJECT_SOURCE_DIR})
# Every relative link in the README and docs/ leads to a file and heading
# that exist (tests/tools/check_doc_links.py).
find_package(Python3 COMPONENTS Interpreter)
if(Python3_FOUND)
  add_test(NAME docs_links COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/tools/check_doc_links.py
    ${PROJECT_SOURCE_DIR})
endif()
