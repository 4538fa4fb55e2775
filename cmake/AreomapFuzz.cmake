# Fuzz targets (tests/fuzz/): one libFuzzer entry point (LLVMFuzzerTestOneInput) per decoder of outside input.
#
# AREOMAP_FUZZ=ON (the `fuzz` preset: clang, build-fuzz/) instruments the whole build with
# -fsanitize=fuzzer-no-link,address,undefined and links the targets with libFuzzer; their CTest entries
# (label `fuzz`) run a short smoke of each. In every other build (AREOMAP_FUZZ=OFF) the same targets link a
# small replay main instead and CTest replays the committed inputs (tests/fuzz/seeds, tests/fuzz/regressions)
# through them, so an input that once crashed stays tested in the release and asan builds too.
option(AREOMAP_FUZZ "Build the fuzz targets with libFuzzer, ASan and UBSan (needs clang)" OFF)

if(AREOMAP_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "AREOMAP_FUZZ needs clang (libFuzzer): cmake --preset fuzz")
  endif()
  set(AREOMAP_FUZZ_FLAGS -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
                         -fno-omit-frame-pointer -gline-tables-only)
  add_compile_options(${AREOMAP_FUZZ_FLAGS})
  add_link_options(-fsanitize=address,undefined)
  enable_testing()
endif()

# tests/fuzz needs the ground readers (OpenCV, GDAL, nlohmann_json): not in the rover-only cross builds.
# It is included after every other folder (deferred to the end of the top-level CMakeLists.txt) so that the
# libraries it links exist.
if(NOT AREOMAP_ROVER_ONLY AND (AREOMAP_FUZZ OR AREOMAP_BUILD_TESTS))
  cmake_language(DEFER CALL include ${PROJECT_SOURCE_DIR}/tests/fuzz/FuzzTargets.cmake)
endif()
