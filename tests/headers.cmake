# Every public header compiles on its own from C and from C++ (extern "C"
# guards, no C-only constructs leaking into the interface), and the
# umbrella header src/chisel.h names every one of them.
file(GLOB CHISEL_PUBLIC_HEADERS
  ${PROJECT_SOURCE_DIR}/src/core/*.h ${PROJECT_SOURCE_DIR}/mesh/*.h
  ${PROJECT_SOURCE_DIR}/shade/*.h ${PROJECT_SOURCE_DIR}/tess/*.h ${PROJECT_SOURCE_DIR}/src/validate/*.h)
list(FILTER CHISEL_PUBLIC_HEADERS EXCLUDE REGEX "_internal\\.h$")
set(includes "")
file(READ ${PROJECT_SOURCE_DIR}/src/chisel.h umbrella)
set(missing "")
foreach(h ${CHISEL_PUBLIC_HEADERS})
  string(APPEND includes "#include \"${h}\"\n")
  get_filename_component(name ${h} NAME)
  string(FIND "${umbrella}" "#include \"${name}\"" at)
  if(at EQUAL -1)
    list(APPEND missing ${name})
  endif()
endforeach()
string(APPEND includes "#include \"${PROJECT_SOURCE_DIR}/src/chisel.h\"\n")
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/headers_c.c "${includes}int main(void) { return 0; }\n")
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/headers_cpp.cpp "${includes}int main() { return 0; }\n")
add_executable(test_headers_c ${CMAKE_CURRENT_BINARY_DIR}/headers_c.c)
add_executable(test_headers_cpp ${CMAKE_CURRENT_BINARY_DIR}/headers_cpp.cpp)
foreach(t test_headers_c test_headers_cpp)
  target_include_directories(${t} PRIVATE ${PROJECT_SOURCE_DIR}/src/core ${PROJECT_SOURCE_DIR}/mesh
    ${PROJECT_SOURCE_DIR}/shade ${PROJECT_SOURCE_DIR}/tess ${PROJECT_SOURCE_DIR}/src/validate
    ${PROJECT_BINARY_DIR}/include)
  target_compile_options(${t} PRIVATE -Werror)
  add_test(NAME ${t} COMMAND ${t})
endforeach()
# A header left out of the umbrella fails at test time, not configure time,
# so the rest of the suite still runs.
add_test(NAME umbrella_header COMMAND ${CMAKE_COMMAND} -E echo "missing from src/chisel.h: ${missing}")
if(missing)
  set_tests_properties(umbrella_header PROPERTIES FAIL_REGULAR_EXPRESSION "missing from")
endif()
