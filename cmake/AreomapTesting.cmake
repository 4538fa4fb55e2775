# areomap_tests: every executable CTest runs (the CppUTest executables, with the tools their tests run through
# their add_dependencies, and the fuzz replays) and nothing else: no benchmark. The asan build presets build
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

# AREOMAP_TEST_GROUPS (a regular expression over `<executable>.<GROUP>`; empty: every group) builds a named
# subset of the CppUTest groups, as the `asan-ci` configure preset does: only the sources that define a matching
# group are compiled (sources without a TEST_GROUP always), only the matching groups are registered, and they
# get the label `subset` (so do the matching fuzz_regressions entries, tests/fuzz/FuzzTargets.cmake), which
# the test preset runs. The CI asan build then compiles none of the test files of groups it does not run
# (~20 % of that build, BENCHMARKS.md "CI").
set(AREOMAP_TEST_GROUPS "" CACHE STRING "Regular expression over <executable>.<GROUP>: build and register only these CppUTest groups (label subset); empty: all")

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
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
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
      list(FIND _areomap_test_cost_${CMAKE_SYSTEM_PROCESSOR} ${name}.${g} _i)
      if(_i GREATER -1)
        math(EXPR _i "${_i} + 1")
        list(GET _areomap_test_cost_${CMAKE_SYSTEM_PROCESSOR} ${_i} _cost)
        set_tests_properties(${name}.${g} PROPERTIES COST ${_cost})
      endif()
    endif()
  endforeach()
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
