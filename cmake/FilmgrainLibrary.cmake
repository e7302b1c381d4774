# filmgrain_installed_library(NAME): what every installed library shares,
# called after add_library(filmgrain_NAME ...) in its folder: the alias
# filmgrain::NAME (the name an installed package's users link too, see
# filmgrainConfig.cmake.in), the file libfilmgrain_NAME.so.VERSION, and the
# public headers of the calling folder's include/.
function(filmgrain_installed_library name)
  set(target filmgrain_${name})
  add_library(filmgrain::${name} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME ${target}
                        VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_compile_features(${target} PUBLIC cxx_std_17)
endfunction()
