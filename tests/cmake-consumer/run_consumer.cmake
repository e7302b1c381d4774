# Driver of the ctest test package.cmake_consumer (see CMakeLists.txt here).
# cmake -DFG_BUILD_DIR=... -DFG_CONFIG=... -DFG_VERSION=... -DFG_LIBDIR=...
#       -DFG_BINDIR=... -DFG_CONSUMER_SOURCE_DIR=... -DFG_WORK_DIR=...
#       -DFG_GENERATOR=... [-DFG_MAKE_PROGRAM=...] [-DFG_CXX_COMPILER=...]
#       -P run_consumer.cmake
# Steps: install the build tree into <work>/prefix; run the installed CLI;
# configure, build and run the consumer against that prefix alone.
cmake_minimum_required(VERSION 3.20)

foreach(_v FG_BUILD_DIR FG_VERSION FG_LIBDIR FG_BINDIR FG_CONSUMER_SOURCE_DIR
           FG_WORK_DIR FG_GENERATOR)
  if(NOT DEFINED ${_v} OR "${${_v}}" STREQUAL "")
    message(FATAL_ERROR "run_consumer.cmake: -D${_v}=... is required")
  endif()
endforeach()

set(_prefix "${FG_WORK_DIR}/prefix")
set(_build "${FG_WORK_DIR}/build")
set(_config_args)
if(FG_CONFIG)
  set(_config_args --config "${FG_CONFIG}")
endif()

function(fg_fail what)
  message(FATAL_ERROR "package.cmake_consumer: FAIL: ${what}\n"
                      "(work directory kept for inspection: ${FG_WORK_DIR})")
endfunction()

# Runs a command, echoing it; fails the test naming the step if it fails.
function(fg_run step)
  string(JOIN " " _cmdline ${ARGN})
  message(STATUS "[${step}] ${_cmdline}")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE _rc)
  if(NOT _rc EQUAL 0)
    fg_fail("${step} failed (exit status: ${_rc})")
  endif()
endfunction()

# A fresh prefix every time: nothing from an earlier install may help.
file(REMOVE_RECURSE "${FG_WORK_DIR}")
file(MAKE_DIRECTORY "${_prefix}" "${_build}")

# 1. Install.
fg_run(install "${CMAKE_COMMAND}" --install "${FG_BUILD_DIR}" --prefix "${_prefix}"
       ${_config_args})
set(_pkgdir "${_prefix}/${FG_LIBDIR}/cmake/filmgrain")
foreach(_f filmgrainConfig.cmake filmgrainConfigVersion.cmake filmgrainTargets.cmake
           FilmgrainFindDeps.cmake)
  if(NOT EXISTS "${_pkgdir}/${_f}")
    fg_fail("the install did not create ${_pkgdir}/${_f}")
  endif()
endforeach()

# 2. The installed CLI runs from the prefix: its RPATH ($ORIGIN/../lib...)
#    must find the installed libraries without LD_LIBRARY_PATH.
set(_cli "${_prefix}/${FG_BINDIR}/filmgrain")
message(STATUS "[installed-cli] ${_cli} --version")
execute_process(COMMAND "${CMAKE_COMMAND}" -E env --unset=LD_LIBRARY_PATH "${_cli}" --version
                RESULT_VARIABLE _rc OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
if(NOT _rc EQUAL 0 OR NOT _out MATCHES "filmgrain ${FG_VERSION}")
  fg_fail("the installed CLI did not run (exit status: ${_rc})\n"
          "stdout: ${_out}\nstderr: ${_err}")
endif()
message(STATUS "[installed-cli] ${_out}")

# 3. Configure the consumer against the prefix only (no package registries).
set(_configure "${CMAKE_COMMAND}" -S "${FG_CONSUMER_SOURCE_DIR}" -B "${_build}"
    -G "${FG_GENERATOR}"
    "-DCMAKE_PREFIX_PATH=${_prefix}"
    -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
    -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
if(FG_CONFIG)
  list(APPEND _configure "-DCMAKE_BUILD_TYPE=${FG_CONFIG}")
endif()
if(FG_MAKE_PROGRAM)
  list(APPEND _configure "-DCMAKE_MAKE_PROGRAM=${FG_MAKE_PROGRAM}")
endif()
if(FG_CXX_COMPILER)
  list(APPEND _configure "-DCMAKE_CXX_COMPILER=${FG_CXX_COMPILER}")
endif()
fg_run(configure ${_configure})

# The package found must be the one just installed.
file(STRINGS "${_build}/CMakeCache.txt" _dir_line REGEX "^filmgrain_DIR:")
string(REGEX REPLACE "^filmgrain_DIR:[A-Z]+=" "" _found_dir "${_dir_line}")
file(REAL_PATH "${_pkgdir}" _want)
if(_found_dir STREQUAL "" OR NOT EXISTS "${_found_dir}")
  fg_fail("filmgrain_DIR not set by the consumer's configure")
endif()
file(REAL_PATH "${_found_dir}" _got)
if(NOT _got STREQUAL _want)
  fg_fail("the consumer found filmgrain in ${_got}, not in the fresh prefix ${_want}")
endif()

# 4. Build and run it ($OCIO unset: the embedded OCIO config is used).
fg_run(build "${CMAKE_COMMAND}" --build "${_build}" ${_config_args})
set(_exe "${_build}/filmgrain_consumer")
if(NOT EXISTS "${_exe}" AND FG_CONFIG)
  set(_exe "${_build}/${FG_CONFIG}/filmgrain_consumer")
endif()
fg_run(run "${CMAKE_COMMAND}" -E env --unset=OCIO --unset=LD_LIBRARY_PATH "${_exe}")

file(REMOVE_RECURSE "${FG_WORK_DIR}")
message(STATUS "package.cmake_consumer: PASS (installed, found, built and ran against a fresh prefix)")
