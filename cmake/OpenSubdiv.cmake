# Debian's OpenSubdivConfig.cmake references static libraries it does not ship
# (see DEPS.md), so find the headers and libosdCPU by hand.
find_path(OSD_INCLUDE_DIR opensubdiv/bfr/surfaceFactory.h REQUIRED)
find_library(OSD_CPU_LIBRARY osdCPU REQUIRED)
add_library(chisel_opensubdiv INTERFACE IMPORTED)
target_include_directories(chisel_opensubdiv SYSTEM INTERFACE ${OSD_INCLUDE_DIR})
target_link_libraries(chisel_opensubdiv INTERFACE ${OSD_CPU_LIBRARY})
