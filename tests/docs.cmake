# The documentation against the program: docs/cli.md names every command and
# every option the CLI accepts (tests/test_docs_cli.sh).
add_test(NAME docs_cli COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_docs_cli.sh $<TARGET_FILE:chisel>
  ${PROJECT_SOURCE_DIR})
