# areomap_tests: every executable CTest runs (the CppUTest executables, with the tools their tests run through
# areomap_test_tools, and the fuzz replays) and nothing else: no benchmark. The asan build presets build
# this target only (`cmake --build --preset asan`), so the sanitizer build skips the benchmarks.
add_custom_target(areomap_tests)
# Sanitizer builds (the asan preset: the C/C++ flags hold -fsanitize=address). The process-level tests
# (scripts that run the tools: e2e, kill-and-resume, soak, navcam replay) run the whole pipeline, which
# ASan + UBSan make several times slower (e2e: ~1 min natively, 10 min under ASan at load 10); their CTest
# TIMEOUT is multiplied by AREOMAP_TEST_TIMEOUT_SCALE there (areomap_script_test_timeout). What they check
# is the same.
if(CMAKE_CXX_FLAGS MATCHES "-fsanitize=[a-z,]*address" OR CMAKE_C_FLAGS MATCHES "-fsanitize=[a-z,]*address")
  set(_scale 3)
else()
  set(_scale 1)
endif()
set(AREOMAP_TEST_TIMEOUT_SCALE ${_scale} CACHE STRING "TIMEOUT factor of the process-level tests (3 in sanitizer builds)")
# areomap_script_test_timeout(TEST SECONDS): TIMEOUT SECONDS x AREOMAP_TEST_TIMEOUT_SCALE.
function(areomap_script_test_timeout test seconds)
  math(EXPR _t "${seconds} * ${AREOMAP_TEST_TIMEOUT_SCALE}")
  set_tests_properties(${test} PROPERTIES TIMEOUT ${_t})
endfunction()

# Under emulation, the long groups start first. A fresh checkout (CI) has no
# Testing/Temporary/CTestCostData.txt, so CTest starts the tests in the order they were added, and a group of
# minutes added late (firmware_match_tests.PanoramaMatcher on powerpc) ran on one core long after the other
# had finished. CTest's COST orders a first run the same way as its cost data orders later runs: seconds per
# group under qemu (build-<target>/Testing/Temporary/CTestCostData.txt, 2-core machine under load,
# 2026-12-04; only the order matters). The golden and HIL tests have theirs in tests/golden, tests/hil.
set(_areomap_test_cost_aarch64
    firmware_match_tests.PanoramaMatcher 152 firmware_adjust_tests.HeldRig 150
    firmware_adjust_tests.FastAdjuster 123 firmware_adjust_tests.ReducedCameraSystem 98
    firmware_match_tests.StereoMatcher 44 firmware_dem_tests.CoarseDem 29 firmware_adjust_tests.SitePoseAdjuster 22
    firmware_adjust_tests.NetworkBuilder 20)
set(_areomap_test_cost_powerpc
    firmware_match_tests.PanoramaMatcher 385 firmware_adjust_tests.HeldRig 308
    firmware_adjust_tests.FastAdjuster 260 firmware_adjust_tests.ReducedCameraSystem 199
    firmware_adjust_tests.NetworkBuilder 108 firmware_adjust_tests.SitePoseAdjuster 97
    firmware_match_tests.StereoMatcher 89 firmware_dem_tests.CoarseDem 68)
# Natively the same holds for the few groups of minutes (the tools on the real pairs, the cross-site matcher,
# the DEM sigma on rendered scenes): in the order they were added, one of them could start last and run alone
# on one core while the other waits. Rough seconds on a 2-core machine (only the order matters); the
# process-level tests set theirs beside their add_test (ground_node_navcam_replay: its first run makes the
# navcam dataset). TraverseTool is the fixture of StreamTraverseGround (tests/ground/node/CMakeLists.txt),
# which waits for it: it starts among the first.
set(_areomap_test_cost_native
    ground_pass_tests.RealPairs 300 ground_traverse_tests.TraverseTool 250 ground_traverse_tests.CrossSiteTies 200
    ground_node_tests.StreamTraverseGround 150 ground_products_calibration_tests.SigmaFollowsNoise 120)

# AREOMAP_TEST_GROUPS (a regular expression over `<executable>.<GROUP>`; empty: every group) builds a named
# subset of the CppUTest groups, as the `asan-ci` configure preset does: only the sources that define a matching
# group are compiled (sources without a TEST_GROUP always), only the matching groups are registered, and they
# get the label `subset` (so do the matching fuzz_regressions entries, tests/fuzz/FuzzTargets.cmake), which
# the test preset runs. The CI asan build then compiles none of the test files of groups it does not run
# (~20 % of that build, BENCHMARKS.md "CI").
set(AREOMAP_TEST_GROUPS "" CACHE STRING "Regular expression over <executable>.<GROUP>: build and register only these CppUTest groups (label subset); empty: all")

# areomap_test_tools(EXECUTABLE TOOL...): the tools (build/bin/) EXECUTABLE's tests run, built before it.
# AREOMAP_TEST_TOOLS (a list of tool targets; empty: all) keeps only those: a build of a named subset of groups
# (AREOMAP_TEST_GROUPS, the `asan-ci` preset) lists the tools its groups run, and the build skips the others.
set(AREOMAP_TEST_TOOLS "" CACHE STRING "The tools the test executables build first (those their groups run); empty: every tool their tests run")
function(areomap_test_tools exe)
  if(NOT TARGET ${exe})
    return()
  endif()
  foreach(tool IN LISTS ARGN)
    if(NOT AREOMAP_TEST_TOOLS OR tool IN_LIST AREOMAP_TEST_TOOLS)
      add_dependencies(${exe} ${tool})
    endif()
  endforeach()
endfunction()

# areomap_cpputest(NAME SOURCES... LIBS... [LABELS ...])
# One CppUTest executable; one CTest entry per TEST_GROUP found in its sources (`-sg GROUP`), so that
# ctest reports every group. Sources are re-read when they change (CMAKE_CONFIGURE_DEPENDS).
function(areomap_cpputest name)
  cmake_parse_arguments(T "" "" "SOURCES;LIBS;LABELS" ${ARGN})
  set(_sources)
  set(_groups)
  foreach(src IN LISTS T_SOURCES)
    get_filename_component(_abs ${src} ABSOLUTE)
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${_abs})
    file(STRINGS ${_abs} _lines REGEX "^[ \t]*TEST_GROUP(_BASE)?[ \t]*\\([ \t]*[A-Za-z0-9_]+")
    set(_src_groups)
    foreach(line IN LISTS _lines)
      string(REGEX REPLACE "^[ \t]*TEST_GROUP(_BASE)?[ \t]*\\([ \t]*([A-Za-z0-9_]+).*" "\\2" _g "${line}")
      if(NOT AREOMAP_TEST_GROUPS OR "${name}.${_g}" MATCHES "${AREOMAP_TEST_GROUPS}")
        list(APPEND _src_groups ${_g})
      endif()
    endforeach()
    if(_src_groups OR NOT _lines)
      list(APPEND _sources ${src})
      list(APPEND _groups ${_src_groups})
    endif()
  endforeach()
  list(REMOVE_DUPLICATES _groups)
  add_executable(${name} ${_sources} ${PROJECT_SOURCE_DIR}/tests/support/TestMain.cpp)
  target_link_libraries(${name} PRIVATE areomap_warnings areomap_test_support PkgConfig::CPPUTEST ${T_LIBS})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests
                        UNITY_BUILD_CODE_BEFORE_INCLUDE "${AREOMAP_UNITY_CPPUTEST_BEFORE_INCLUDE}")
  add_dependencies(areomap_tests ${name})
  set(_labels ${T_LABELS})
  if(AREOMAP_TEST_GROUPS)
    list(APPEND _labels subset)
  endif()
  # A test that runs its own binary again (tests/platform/UdpmTest.cpp) needs the emulator of a cross build.
  set(_env "AREOMAP_SOURCE_DIR=${PROJECT_SOURCE_DIR}" "AREOMAP_BINARY_DIR=${CMAKE_BINARY_DIR}")
  if(CMAKE_CROSSCOMPILING_EMULATOR)
    list(JOIN CMAKE_CROSSCOMPILING_EMULATOR " " _emulator)
    list(APPEND _env "AREOMAP_TEST_EMULATOR=${_emulator}")
  endif()
  foreach(g IN LISTS _groups)
    add_test(NAME ${name}.${g} COMMAND ${name} -sg ${g} -v
             WORKING_DIRECTORY ${CMAKE_BINARY_DIR})
    set_tests_properties(${name}.${g} PROPERTIES SKIP_RETURN_CODE 77
                         ENVIRONMENT "${_env}")
    if(_labels)
      set_tests_properties(${name}.${g} PROPERTIES LABELS "${_labels}")
    endif()
    if(CMAKE_CROSSCOMPILING_EMULATOR)
      set(_costs ${_areomap_test_cost_${CMAKE_SYSTEM_PROCESSOR}})
    elseif(NOT CMAKE_CROSSCOMPILING)
      set(_costs ${_areomap_test_cost_native})
    else()
      set(_costs)
    endif()
    list(FIND _costs ${name}.${g} _i)
    if(_i GREATER -1)
      math(EXPR _i "${_i} + 1")
      list(GET _costs ${_i} _cost)
      set_tests_properties(${name}.${g} PROPERTIES COST ${_cost})
    endif()
  endforeach()
endfunction()

# The `tiny` panorama of seed 3 that many ground groups read (tests/support/TestData.hpp makeTinyDataset):
# rendered once per ctest run by the fixture tiny_dataset (tests/ground/CMakeLists.txt) into this folder.
set(AREOMAP_TINY_DATASET_DIR ${CMAKE_BINARY_DIR}/test-scratch/tiny-seed3/sim)
# areomap_fixture_groups(EXECUTABLE FIXTURE VAR=VALUE GROUP...): those groups (of the current folder) require
# the CTest fixture and get VAR=VALUE in their environment, which tells them to read what it made.
function(areomap_fixture_groups exe fixture env)
  foreach(g IN LISTS ARGN)
    if(TEST ${exe}.${g})
      set_tests_properties(${exe}.${g} PROPERTIES FIXTURES_REQUIRED ${fixture})
      set_property(TEST ${exe}.${g} APPEND PROPERTY ENVIRONMENT "${env}")
    endif()
  endforeach()
endfunction()
# areomap_tiny_dataset_groups(EXECUTABLE GROUP...): those groups read the fixture's panorama instead of
# rendering their own.
function(areomap_tiny_dataset_groups exe)
  areomap_fixture_groups(${exe} tiny_dataset "AREOMAP_TINY_DATASET=${AREOMAP_TINY_DATASET_DIR}" ${ARGN})
endfunction()

# areomap_test_folder(NAME LIBS... [LABELS ...]): all *Test.cpp in the current folder, one executable.
function(areomap_test_folder name)
  cmake_parse_arguments(T "" "" "LIBS;LABELS" ${ARGN})
  file(GLOB _srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*Test.cpp)
  if(_srcs)
    areomap_cpputest(${name} SOURCES ${_srcs} LIBS ${T_LIBS} LABELS ${T_LABELS})
  endif()
endfunction()
include(AreomapFuzz)
# The fuzz targets are defined at the end of the configure (AreomapFuzz.cmake defers them); this call is
# deferred after them.
function(_areomap_tests_add_fuzz)
  if(TARGET fuzz_targets)
    add_dependencies(areomap_tests fuzz_targets)
  endif()
endfunction()
cmake_language(DEFER CALL _areomap_tests_add_fuzz)
