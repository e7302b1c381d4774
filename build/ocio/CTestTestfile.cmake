# CMake generated Testfile for 
# Source directory: /work/main/ocio
# Build directory: /work/main/build/ocio
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
include("/work/main/build/ocio/ocio_test[1]_include.cmake")
add_test([=[ocio.ociocheck_minimal_config]=] "/usr/bin/ociocheck" "--iconfig" "/work/main/ocio/src/filmgrain_minimal.ocio")
set_tests_properties([=[ocio.ociocheck_minimal_config]=] PROPERTIES  FAIL_REGULAR_EXPRESSION "ERROR" _BACKTRACE_TRIPLES "/work/main/ocio/CMakeLists.txt;54;add_test;/work/main/ocio/CMakeLists.txt;0;")
