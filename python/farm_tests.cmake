# filmgrain-farm's tests (python/tests/test_farm.py): Dask local clusters of
# 2 workers running the built CLI; outputs compared with the CLI's bit for
# bit. Included from the top-level CMakeLists.txt with FILMGRAIN_BUILD_TESTS,
# whatever FILMGRAIN_BUILD_PYTHON says; needs Debian's python3-dask and
# python3-distributed (scripts/debian-packages.txt), and not the compiled
# Python module: the farm is loaded from the source tree (--noconftest: the
# module's conftest.py imports the extension).
# RUN_SERIAL: the lost-worker test kills a worker while frames run, and each
# test starts worker processes; about 50 s on 2 loaded cores.
add_test(NAME python.farm
  COMMAND ${FILMGRAIN_PYTHON} -m pytest -q -p no:cacheprovider --noconftest
          --rootdir=${CMAKE_CURRENT_LIST_DIR}
          --basetemp=${CMAKE_CURRENT_BINARY_DIR}/tmp-farm
          ${CMAKE_CURRENT_LIST_DIR}/tests/test_farm.py)
set_tests_properties(python.farm PROPERTIES
  ENVIRONMENT "FILMGRAIN_BIN=$<TARGET_FILE:filmgrain>;PYTHONPATH=${CMAKE_CURRENT_LIST_DIR};PYTHONDONTWRITEBYTECODE=1"
  RUN_SERIAL TRUE LABELS python
  TIMEOUT 600)
