# filmgrain_add_pytest(NAME test SPEC file.py[::test] ROOTDIR dir TIMEOUT s
#                      LABELS label... [ENVIRONMENT VAR=value...] [ARGS arg...])
#
# One ctest test running pytest with FILMGRAIN_PYTHON (Debian's python3:
# it imports OpenImageIO) on SPEC: no pytest cache and no bytecode in the
# source tree, its temporary files in the build tree (tmp-<test>), the
# built CLI in FILMGRAIN_BIN. ARGS go to pytest before the SPEC.
function(filmgrain_add_pytest)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "NAME;SPEC;ROOTDIR;TIMEOUT"
                        "LABELS;ENVIRONMENT;ARGS")
  add_test(NAME ${arg_NAME}
    COMMAND ${FILMGRAIN_PYTHON} -m pytest -q -p no:cacheprovider ${arg_ARGS}
            --rootdir=${arg_ROOTDIR}
            --basetemp=${CMAKE_CURRENT_BINARY_DIR}/tmp-${arg_NAME}
            "${arg_SPEC}")
  set(env "FILMGRAIN_BIN=$<TARGET_FILE:filmgrain>" "PYTHONDONTWRITEBYTECODE=1"
      ${arg_ENVIRONMENT})
  set_tests_properties(${arg_NAME} PROPERTIES
    ENVIRONMENT "${env}" TIMEOUT ${arg_TIMEOUT} LABELS "${arg_LABELS}")
endfunction()
