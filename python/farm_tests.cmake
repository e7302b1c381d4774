# filmgrain-farm's tests (python/tests/test_farm.py): Dask local clusters of
# 2 workers running the built CLI; outputs compared with the CLI's bit for
# bit. Included from the top-level CMakeLists.txt with FILMGRAIN_BUILD_TESTS,
# whatever FILMGRAIN_BUILD_PYTHON says; needs Debian's python3-dask and
# python3-distributed (scripts/debian-packages.txt), and not the compiled
# Python module: the farm is loaded from the source tree (--noconftest: the
# module's conftest.py imports the extension).
# RUN_SERIAL: the lost-worker test kills a worker while frames run, and each
# test starts worker processes; about 50 s on 2 loaded cores.
filmgrain_add_pytest(NAME python.farm SPEC ${CMAKE_CURRENT_LIST_DIR}/tests/test_farm.py
                     ROOTDIR ${CMAKE_CURRENT_LIST_DIR} ARGS --noconftest
                     TIMEOUT 600 LABELS python
                     ENVIRONMENT "PYTHONPATH=${CMAKE_CURRENT_LIST_DIR}")
set_tests_properties(python.farm PROPERTIES RUN_SERIAL TRUE)
