# Fuzz targets of every decoder of outside input (tests/README.md, "Fuzzing"), included from
# cmake/AreomapFuzz.cmake at the end of the top-level CMakeLists.txt. Each FooFuzz.cpp defines
# LLVMFuzzerTestOneInput; fuzz_foo links libFuzzer (AREOMAP_FUZZ, the `fuzz` preset) or ReplayMain.cpp.
#   lcm_message  msgs::decodeMessage<T> for all 9 types (first byte picks the type) + msgs/adapters checks
#   lcm_log      platform LcmLogReplay over a log file, each event decoded as a stereo pair
#   jpeg         platform ArenaJpegDecoder and TurboJpegCodec into the rover's fixed buffers
#   pds3         PDS3 labels and image bodies (ground/io Pds3Label parsed once per input, readPds3ImageInfo,
#                readPds3Image8, readPds3Camera)
#   camera_file  camera model text: core parseModelText (.cahvor) and ground/io parseCameraText (JPL text,
#                PDS3 label, M2020 metadata JSON)
#   panorama     panorama.json (ground/dataset readDataset)
#   tiepoints    tie-point / observation / check-point CSV (ground/dataset readObservationsCsv, readPointsCsv)
#   site         a traverse's site announcement (site_t, AREOMAP_SITE): msgs/adapters decodeSite + checkSite
set(AREOMAP_FUZZ_TARGETS lcm_message lcm_log jpeg pds3 camera_file panorama tiepoints site)
set(_libs_lcm_message areomap_msg_adapters areomap_msgs areomap_camera)
set(_libs_lcm_log areomap_platform areomap_msg_adapters areomap_msgs areomap_camera)
set(_libs_jpeg areomap_platform)
set(_libs_pds3 areomap_ground_io)
set(_libs_camera_file areomap_ground_io areomap_camera)
set(_libs_panorama areomap_dataset)
set(_libs_tiepoints areomap_dataset)
set(_libs_site areomap_msg_adapters areomap_msgs areomap_camera)
set(_src_lcm_message ${CMAKE_CURRENT_LIST_DIR}/LcmMessageFuzz.cpp)
set(_src_lcm_log ${CMAKE_CURRENT_LIST_DIR}/LcmLogFuzz.cpp)
set(_src_jpeg ${CMAKE_CURRENT_LIST_DIR}/JpegFuzz.cpp)
set(_src_pds3 ${CMAKE_CURRENT_LIST_DIR}/Pds3Fuzz.cpp)
set(_src_camera_file ${CMAKE_CURRENT_LIST_DIR}/CameraFileFuzz.cpp)
set(_src_panorama ${CMAKE_CURRENT_LIST_DIR}/PanoramaFuzz.cpp)
set(_src_tiepoints ${CMAKE_CURRENT_LIST_DIR}/TiePointsFuzz.cpp)
set(_src_site ${CMAKE_CURRENT_LIST_DIR}/SiteFuzz.cpp)

set(_fuzz_dir ${CMAKE_BINARY_DIR}/fuzz)
add_custom_target(fuzz_targets)
foreach(t IN LISTS AREOMAP_FUZZ_TARGETS)
  if(AREOMAP_FUZZ)
    add_executable(fuzz_${t} ${_src_${t}} ${CMAKE_CURRENT_LIST_DIR}/FuzzSupport.cpp)
    target_link_options(fuzz_${t} PRIVATE -fsanitize=fuzzer)
  else()
    add_executable(fuzz_${t} ${_src_${t}} ${CMAKE_CURRENT_LIST_DIR}/FuzzSupport.cpp ${CMAKE_CURRENT_LIST_DIR}/ReplayMain.cpp)
  endif()
  target_link_libraries(fuzz_${t} PRIVATE areomap_warnings ${_libs_${t}} areomap_camera)
  target_include_directories(fuzz_${t} PRIVATE ${PROJECT_SOURCE_DIR})
  set_target_properties(fuzz_${t} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${_fuzz_dir})
  add_dependencies(fuzz_targets fuzz_${t})
  # The committed inputs: hand-made seeds and every input that once crashed (tests/fuzz/regressions/<t>/).
  set(_inputs ${CMAKE_CURRENT_LIST_DIR}/seeds/${t} ${CMAKE_CURRENT_LIST_DIR}/regressions/${t})
  if(AREOMAP_FUZZ)
    # Smoke: ~8 s per target from the generated corpus (tests/fuzz/run.sh makes it) and the committed inputs.
    add_test(NAME fuzz_smoke.${t}
             COMMAND ${CMAKE_CURRENT_LIST_DIR}/run.sh --build-dir ${CMAKE_BINARY_DIR} --no-build
                     --only ${t} --seconds-each 8)
    set_tests_properties(fuzz_smoke.${t} PROPERTIES LABELS "fuzz" TIMEOUT 300)
  endif()
  if(AREOMAP_FUZZ)
    # libFuzzer: -runs=0 executes the given inputs only; it refuses a folder that does not exist (a new
    # regressions/<t>/ folder needs a re-configure here; ReplayMain skips missing folders).
    set(_existing)
    foreach(d IN LISTS _inputs)
      if(EXISTS ${d})
        list(APPEND _existing ${d})
      endif()
    endforeach()
    add_test(NAME fuzz_regressions.${t} COMMAND fuzz_${t} -runs=0 ${_existing})
  else()
    add_test(NAME fuzz_regressions.${t} COMMAND fuzz_${t} ${_inputs})
  endif()
  set(_labels fuzz-replay)
  if(AREOMAP_TEST_GROUPS AND "fuzz_regressions.${t}" MATCHES "${AREOMAP_TEST_GROUPS}")
    list(APPEND _labels subset)  # the named subset of a build (cmake/AreomapTesting.cmake)
  endif()
  set_tests_properties(fuzz_regressions.${t} PROPERTIES LABELS "${_labels}" TIMEOUT 300)
endforeach()

# The seed maker: small valid inputs made with the project's own encoders (LCM messages of every type with
# small JPEGs, LCM logs, JPEGs, camera model text); tests/fuzz/run.sh adds the real files of ../shared/data
# and a simulated panorama.
add_executable(fuzz_seeds ${CMAKE_CURRENT_LIST_DIR}/FuzzSeeds.cpp ${PROJECT_SOURCE_DIR}/tests/platform/MessageFixtures.cpp)
target_link_libraries(fuzz_seeds PRIVATE areomap_warnings areomap_platform areomap_msg_adapters areomap_msgs areomap_camera)
target_include_directories(fuzz_seeds PRIVATE ${PROJECT_SOURCE_DIR})
set_target_properties(fuzz_seeds PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${_fuzz_dir})
add_dependencies(fuzz_targets fuzz_seeds)
