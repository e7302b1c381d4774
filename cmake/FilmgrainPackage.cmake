# The installed CMake package: lets studio tools do
#
#   find_package(filmgrain 0.1 CONFIG REQUIRED)
#   target_link_libraries(tool PRIVATE filmgrain::oiio filmgrain::ocio)
#
# Installed into <prefix>/${CMAKE_INSTALL_LIBDIR}/cmake/filmgrain:
#   filmgrainTargets*.cmake       the export set `filmgraintargets`
#                                 (filmgrain::core, filmgrain::ocio, filmgrain::oiio)
#   filmgrainConfig.cmake         from filmgrainConfig.cmake.in: finds the
#                                 dependencies, repairs Debian's OIIO/OCIO packages
#   filmgrainConfigVersion.cmake  SameMajorVersion
#   FilmgrainFindDeps.cmake       the repairs, shared with our own build
# tests/cmake-consumer checks the result (ctest -R package).
# Included at the end of the top-level CMakeLists.txt, after every target.

include(CMakePackageConfigHelpers)

set(FILMGRAIN_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/filmgrain")

# Whether the libraries are static: their private dependencies (Threads,
# nlohmann_json, OpenColorIO) then appear in the exported link interface as
# $<LINK_ONLY:...> and the Config file must find them too.
if(BUILD_SHARED_LIBS)
  set(FILMGRAIN_PACKAGE_STATIC OFF)
else()
  set(FILMGRAIN_PACKAGE_STATIC ON)
endif()

install(EXPORT filmgraintargets
  NAMESPACE filmgrain::
  FILE filmgrainTargets.cmake
  DESTINATION "${FILMGRAIN_INSTALL_CMAKEDIR}")

configure_package_config_file(
  "${PROJECT_SOURCE_DIR}/cmake/filmgrainConfig.cmake.in"
  "${PROJECT_BINARY_DIR}/filmgrainConfig.cmake"
  INSTALL_DESTINATION "${FILMGRAIN_INSTALL_CMAKEDIR}"
  NO_SET_AND_CHECK_MACRO)

write_basic_package_version_file(
  "${PROJECT_BINARY_DIR}/filmgrainConfigVersion.cmake"
  VERSION ${PROJECT_VERSION}
  COMPATIBILITY SameMajorVersion)

install(FILES
  "${PROJECT_BINARY_DIR}/filmgrainConfig.cmake"
  "${PROJECT_BINARY_DIR}/filmgrainConfigVersion.cmake"
  "${PROJECT_SOURCE_DIR}/cmake/FilmgrainFindDeps.cmake"
  DESTINATION "${FILMGRAIN_INSTALL_CMAKEDIR}")
