# The installed package: find_package(chisel) and pkg-config consumers
# (tests/test_install.sh). Only in plain builds: the sanitizer and fuzz
# builds' libraries need their runtime flags on every consumer's link line.
if(CMAKE_BUILD_TYPE STREQUAL "Release" AND NOT CHISEL_FUZZ)
  add_test(NAME install_package COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_install.sh
    ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_BINARY_DIR}/install_tmp
    ${CMAKE_C_COMPILER} ${CMAKE_CXX_COMPILER})
endif()
