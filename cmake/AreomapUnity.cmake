# Unity builds (CMAKE_UNITY_BUILD=ON) for the builds whose binaries are only tested, never shipped: the
# asan-ci and fuzz presets (CMakePresets.json), CI's native build (./setup.sh --unity) and CI's aarch64 build
# (.ci/run: its rover runs only under qemu). Each
# target's sources are compiled a few at a time as one translation unit, so the heavy headers (Eigen, OpenCV,
# CppUTest) are parsed once per batch instead of once per file. The native preset and ./setup.sh without
# --unity stay one file per translation unit: the developers' build, where a file that compiles alone is what
# is checked (in CI the powerpc preset checks it for the rover side).
#
# A batch is a run of neighbouring files in the target's source list, and a file added or removed moves the
# others between batches: names in anonymous namespaces (and file-scope statics) are kept unique within the
# whole target, test files included, not only within today's batch; a file that keeps a clashing name is
# listed below.
#
# Files that cannot share a translation unit with the others of their target, and why. The path is
# relative to the source tree; the property is set on every target that compiles the file.
set(AREOMAP_UNITY_SKIP
    # Constants and helpers of the same name in an anonymous namespace of another file of the target
    # (kBehindCameraCost, kDeg, num, kPi, kDegToRad, readError, code): each file keeps its own.
    firmware_core/adjust/SitePoseAdjuster.cpp
    ground/sim/SimConfig.cpp
    ground/sim/SimGeometry.cpp
    ground/sim/TraversePlan.cpp
    ground/traverse/DemRegistration.cpp
    tests/firmware_core/adjust/SyntheticTraverse.cpp
    tests/ground/dataset/TraverseTest.cpp
)
# Targets built one file per translation unit even so: nearly every test file of platform_tests defines its
# helpers under the same names in an anonymous namespace (code, Received, roundTrip).
set(AREOMAP_UNITY_OFF_TARGETS platform_tests)

# The CppUTest executables: <CppUTest/TestHarness.h> defines `new` as a macro (its leak detector's file and
# line) at the end of the first test file, which breaks the standard headers a later file of the same batch
# includes. The leak detector is off in every test executable (tests/support/TestMain.cpp), so the macro only
# named the place of an allocation it no longer watches; it is undefined before each file.
set(AREOMAP_UNITY_CPPUTEST_BEFORE_INCLUDE "#ifdef CPPUTEST_USE_NEW_MACROS\n#undef new\n#endif")

# Sets UNITY_BUILD OFF on the targets of AREOMAP_UNITY_OFF_TARGETS and SKIP_UNITY_BUILD_INCLUSION on the
# files of AREOMAP_UNITY_SKIP, in the scope of each target that has them (a source file property is per
# directory). Deferred to the end of the configure, after every target,
# the fuzz targets included.
function(_areomap_unity_skip_dir dir)
  get_property(_targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  foreach(t IN LISTS _targets)
    get_target_property(_type ${t} TYPE)
    if(_type STREQUAL "INTERFACE_LIBRARY" OR _type STREQUAL "UTILITY")
      continue()
    endif()
    if(t IN_LIST AREOMAP_UNITY_OFF_TARGETS)
      set_target_properties(${t} PROPERTIES UNITY_BUILD OFF)
      continue()
    endif()
    get_target_property(_srcs ${t} SOURCES)
    get_target_property(_tdir ${t} SOURCE_DIR)
    foreach(s IN LISTS _srcs)
      if(s MATCHES "^\\$<")
        continue()
      endif()
      get_filename_component(_abs ${s} ABSOLUTE BASE_DIR ${_tdir})
      file(RELATIVE_PATH _rel ${PROJECT_SOURCE_DIR} ${_abs})
      if(_rel IN_LIST AREOMAP_UNITY_SKIP)
        set_source_files_properties(${_abs} TARGET_DIRECTORY ${t} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
      endif()
    endforeach()
  endforeach()
  get_property(_subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(d IN LISTS _subdirs)
    _areomap_unity_skip_dir(${d})
  endforeach()
endfunction()
function(_areomap_unity_skip)
  _areomap_unity_skip_dir(${PROJECT_SOURCE_DIR})
endfunction()
if(CMAKE_UNITY_BUILD)
  cmake_language(DEFER CALL _areomap_unity_skip)
endif()
