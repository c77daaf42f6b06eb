# Installing chisel as a package: `cmake --install build [--prefix P]` puts
#   bin/chisel                          the command line
#   lib/libchisel_{core,mesh,shade,tess,validate}.a
#   include/chisel/chisel.h             the umbrella header, beside every
#   include/chisel/ch_*.h               public header and ch_version.h
#   lib/cmake/chisel/chiselConfig.cmake find_package(chisel) with targets
#                                       chisel::core ... chisel::validate and
#                                       chisel::chisel (all of them)
#   lib/pkgconfig/chisel.pc             pkg-config --cflags --libs chisel
# The libraries are static; the config file finds their dependencies again
# (find_dependency) so that consumers link them.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(CHISEL_LIBRARIES chisel_core chisel_mesh chisel_shade chisel_tess chisel_validate)
foreach(lib ${CHISEL_LIBRARIES})
  string(REPLACE "chisel_" "" short ${lib})
  set_target_properties(${lib} PROPERTIES EXPORT_NAME ${short})
  target_include_directories(${lib} INTERFACE
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/chisel> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
endforeach()

# chisel::chisel: every library and the umbrella header.
add_library(chisel_all INTERFACE)
set_target_properties(chisel_all PROPERTIES EXPORT_NAME chisel)
target_link_libraries(chisel_all INTERFACE ${CHISEL_LIBRARIES})
target_include_directories(chisel_all INTERFACE $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>)
add_library(chisel::chisel ALIAS chisel_all)

install(TARGETS chisel RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS ${CHISEL_LIBRARIES} chisel_all EXPORT chiselTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})

# Public headers: every header of the library folders (private ones, if a
# module ever needs them, end in _internal.h and stay behind).
foreach(dir src/core mesh shade tess src/validate)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/chisel
          FILES_MATCHING PATTERN "*.h" PATTERN "*_internal.h" EXCLUDE)
endforeach()
install(FILES ${PROJECT_SOURCE_DIR}/src/chisel.h ${PROJECT_BINARY_DIR}/include/ch_version.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/chisel)

set(CHISEL_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/chisel)
install(EXPORT chiselTargets NAMESPACE chisel:: DESTINATION ${CHISEL_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/chiselConfig.cmake.in
  ${PROJECT_BINARY_DIR}/chiselConfig.cmake INSTALL_DESTINATION ${CHISEL_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/chiselConfigVersion.cmake
  COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/chiselConfig.cmake ${PROJECT_BINARY_DIR}/chiselConfigVersion.cmake
        DESTINATION ${CHISEL_CMAKE_DIR})

# pkg-config: static libraries, so Libs names every dependency as well.
# The OpenMP runtime the libraries were built against (gcc: gomp, clang: omp).
set(CHISEL_PC_OPENMP "")
foreach(lib ${OpenMP_C_LIBRARIES})
  if(lib MATCHES "pthread")
    string(APPEND CHISEL_PC_OPENMP " -pthread")
  else()
    string(APPEND CHISEL_PC_OPENMP " ${lib}")
  endif()
endforeach()
file(RELATIVE_PATH CHISEL_PC_TO_PREFIX /p/${CMAKE_INSTALL_LIBDIR}/pkgconfig /p)
configure_file(${PROJECT_SOURCE_DIR}/cmake/chisel.pc.in ${PROJECT_BINARY_DIR}/chisel.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/chisel.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
