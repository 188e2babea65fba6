# cmake --install: the public headers under include/gradraster (so
# "autodiff/base/tensor.h" keeps working; cmake/public_headers.cmake says
# which), the three libraries, a CMake package (find_package(gradraster)
# gives gradraster::gradraster) and a pkg-config file. Everything here is in the
# "dev" component; tests/package installs just that, then the "python" component
# (the Python package, python/CMakeLists.txt).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(GRADRASTER_INCLUDE_SUBDIR ${CMAKE_INSTALL_INCLUDEDIR}/gradraster)
set(GRADRASTER_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/gradraster)

include(cmake/public_headers.cmake)  # GRADRASTER_INSTALLED_HEADERS: the API and what it includes
foreach(header IN LISTS GRADRASTER_INSTALLED_HEADERS)
  get_filename_component(folder ${header} DIRECTORY)
  install(FILES ${header} DESTINATION ${GRADRASTER_INCLUDE_SUBDIR}/${folder} COMPONENT dev)
endforeach()
install(TARGETS gradraster_base gradraster_raster gradraster EXPORT gradrasterTargets
  COMPONENT dev
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(EXPORT gradrasterTargets NAMESPACE gradraster:: DESTINATION ${GRADRASTER_CMAKE_DIR}
  COMPONENT dev)

configure_package_config_file(cmake/gradrasterConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/gradrasterConfig.cmake INSTALL_DESTINATION ${GRADRASTER_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/gradrasterConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/gradrasterConfig.cmake
  ${CMAKE_CURRENT_BINARY_DIR}/gradrasterConfigVersion.cmake
  DESTINATION ${GRADRASTER_CMAKE_DIR} COMPONENT dev)

# The .pc file finds its prefix from its own folder, so the tree can be installed anywhere.
# Its Cflags carry the same usage requirements as the CMake targets (the
# PUBLIC compile options of gradraster_base), so both kinds of consumer compile
# alike; the build's machine flags (GRADRASTER_NATIVE) are in neither.
string(JOIN " " GRADRASTER_PC_CFLAGS ${GRADRASTER_CONSUMER_COMPILE_OPTIONS})
file(RELATIVE_PATH GRADRASTER_PC_TO_PREFIX ${CMAKE_INSTALL_FULL_LIBDIR}/pkgconfig ${CMAKE_INSTALL_PREFIX})
configure_file(cmake/gradraster.pc.in ${CMAKE_CURRENT_BINARY_DIR}/gradraster.pc @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/gradraster.pc
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)
