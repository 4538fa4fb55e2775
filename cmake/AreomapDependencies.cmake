# Every dependency comes from a Debian package (setup.sh installs them).
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(Threads REQUIRED)

# LCM: Debian's pkg-config file pulls in glib; find the library and header directly.
# AREOMAP_WITH_LCM_RUNTIME=OFF (the powerpc toolchain: Debian has no LCM for it) uses LCM's headers only:
# the generated message code needs only lcm_coretypes.h; the LCM transport is left out (platform/posix).
option(AREOMAP_WITH_LCM_RUNTIME "Link LCM's runtime library (udpm/file transports)" ON)
find_path(LCM_INCLUDE_DIR lcm/lcm_coretypes.h REQUIRED)
if(AREOMAP_WITH_LCM_RUNTIME)
  find_library(LCM_LIBRARY NAMES lcm REQUIRED)
endif()
find_program(LCM_GEN_EXECUTABLE lcm-gen)
if(NOT LCM_GEN_EXECUTABLE)
  message(FATAL_ERROR "lcm-gen not found: install liblcm-bin (./setup.sh does)")
endif()
if(AREOMAP_WITH_LCM_RUNTIME)
  add_library(lcm::lcm UNKNOWN IMPORTED)
  set_target_properties(lcm::lcm PROPERTIES IMPORTED_LOCATION ${LCM_LIBRARY}
                                            INTERFACE_INCLUDE_DIRECTORIES ${LCM_INCLUDE_DIR})
else()
  add_library(lcm::lcm INTERFACE IMPORTED)
  set_target_properties(lcm::lcm PROPERTIES INTERFACE_INCLUDE_DIRECTORIES ${LCM_INCLUDE_DIR})
endif()

# TurboJPEG through libjpeg-turbo's CMake package.
find_package(libjpeg-turbo REQUIRED)
if(TARGET libjpeg-turbo::turbojpeg)
  set(AREOMAP_TURBOJPEG libjpeg-turbo::turbojpeg)
else()
  set(AREOMAP_TURBOJPEG libjpeg-turbo::turbojpeg-static)
endif()
# A static-only libjpeg-turbo (the powerpc target builds it from source) has jpeg-static only.
if(NOT TARGET libjpeg-turbo::jpeg AND TARGET libjpeg-turbo::jpeg-static)
  add_library(libjpeg-turbo::jpeg INTERFACE IMPORTED)
  set_target_properties(libjpeg-turbo::jpeg PROPERTIES INTERFACE_LINK_LIBRARIES libjpeg-turbo::jpeg-static)
endif()

find_package(PkgConfig REQUIRED)
if(AREOMAP_BUILD_TESTS)
  # CppUTest through pkg-config: Debian's CppUTest CMake config points at wrong paths.
  pkg_check_modules(CPPUTEST REQUIRED IMPORTED_TARGET cpputest)
endif()

if(NOT AREOMAP_ROVER_ONLY)
  find_package(OpenCV REQUIRED COMPONENTS core imgproc imgcodecs calib3d features2d)
  find_package(GDAL REQUIRED)
  find_package(Ceres REQUIRED)
  find_package(nlohmann_json 3 REQUIRED)
endif()
