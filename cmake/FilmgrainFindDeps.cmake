# Finds OpenImageIO and OpenColorIO as installed by Debian 12 and repairs the
# two known defects of their CMake packages (see ../shared/DEBIAN12-NOTES.md):
#  - OpenColorIOConfig.cmake lives in /usr/share/cmake (not searched by
#    default) and computes its include directory as "/include";
#  - OpenImageIO::OpenImageIO lists /usr/include/opencv4, which only exists
#    with libopencv-dev installed: CMake then fails at generate time.
# This file is installed next to filmgrainConfig.cmake and included there, so
# consumers of the installed package get the same repairs.

include_guard(GLOBAL)
include(CMakeFindDependencyMacro)

macro(filmgrain_find_opencolorio)
  if(NOT TARGET OpenColorIO::OpenColorIO)
    if(CMAKE_FIND_PACKAGE_NAME)  # inside a package's Config file
      find_dependency(OpenColorIO 2.1 CONFIG PATHS /usr/share/cmake)
    else()  # our own build: a missing dependency must fail the configure
      find_package(OpenColorIO 2.1 CONFIG REQUIRED PATHS /usr/share/cmake)
    endif()
  endif()
  get_target_property(_fg_ocio_inc OpenColorIO::OpenColorIO INTERFACE_INCLUDE_DIRECTORIES)
  set(_fg_ocio_ok FALSE)
  foreach(_d IN LISTS _fg_ocio_inc)
    if(EXISTS "${_d}/OpenColorIO/OpenColorIO.h")
      set(_fg_ocio_ok TRUE)
    endif()
  endforeach()
  if(NOT _fg_ocio_ok)
    find_path(FILMGRAIN_OCIO_INCLUDE_DIR OpenColorIO/OpenColorIO.h REQUIRED)
    set_target_properties(OpenColorIO::OpenColorIO PROPERTIES
      INTERFACE_INCLUDE_DIRECTORIES "${FILMGRAIN_OCIO_INCLUDE_DIR}")
  endif()
endmacro()

macro(filmgrain_find_openimageio)
  if(NOT TARGET OpenImageIO::OpenImageIO)
    if(CMAKE_FIND_PACKAGE_NAME)
      find_dependency(OpenImageIO 2.4 CONFIG)
    else()
      find_package(OpenImageIO 2.4 CONFIG REQUIRED)
    endif()
  endif()
  foreach(_fg_tgt OpenImageIO::OpenImageIO OpenImageIO::OpenImageIO_Util)
    if(TARGET ${_fg_tgt})
      foreach(_fg_prop INTERFACE_INCLUDE_DIRECTORIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES)
        get_target_property(_fg_dirs ${_fg_tgt} ${_fg_prop})
        if(_fg_dirs)
          set(_fg_keep)
          foreach(_d IN LISTS _fg_dirs)
            if(EXISTS "${_d}")
              list(APPEND _fg_keep "${_d}")
            endif()
          endforeach()
          set_target_properties(${_fg_tgt} PROPERTIES ${_fg_prop} "${_fg_keep}")
        endif()
      endforeach()
    endif()
  endforeach()
endmacro()
