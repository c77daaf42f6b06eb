# Every public header compiles on its own from C and from C++ (extern "C"
# guards, no C-only constructs leaking into the interface).
file(GLOB CHISEL_PUBLIC_HEADERS
  ${PROJECT_SOURCE_DIR}/src/core/*.h ${PROJECT_SOURCE_DIR}/mesh/*.h
  ${PROJECT_SOURCE_DIR}/shade/*.h ${PROJECT_SOURCE_DIR}/tess/*.h)
set(includes "")
foreach(h ${CHISEL_PUBLIC_HEADERS})
  string(APPEND includes "#include \"${h}\"\n")
endforeach()
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/headers_c.c "${includes}int main(void) { return 0; }\n")
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/headers_cpp.cpp "${includes}int main() { return 0; }\n")
add_executable(test_headers_c ${CMAKE_CURRENT_BINARY_DIR}/headers_c.c)
add_executable(test_headers_cpp ${CMAKE_CURRENT_BINARY_DIR}/headers_cpp.cpp)
foreach(t test_headers_c test_headers_cpp)
  target_include_directories(${t} PRIVATE ${PROJECT_SOURCE_DIR}/src/core ${PROJECT_SOURCE_DIR}/mesh
    ${PROJECT_SOURCE_DIR}/shade ${PROJECT_SOURCE_DIR}/tess)
  target_compile_options(${t} PRIVATE -Werror)
  add_test(NAME ${t} COMMAND ${t})
endforeach()
