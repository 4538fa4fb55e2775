# Every dependency comes from a Debian package (setup.sh installs them).
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(Threads REQUIRED)

# LCM: Debian's pkg-config file pulls in glib; find the library and header directly.
find_path(LCM_INCLUDE_DIR lcm/lcm.h REQUIRED)
find_library(LCM_LIBRARY NAMES lcm REQUIRED)
find_program(LCM_GEN_EXECUTABLE lcm-gen)
if(NOT LCM_GEN_EXECUTABLE)
  message(FATAL_ERROR "lcm-gen not found: install liblcm-bin (./setup.sh does)")
endif()
add_library(lcm::lcm UNKNOWN IMPORTED)
set_target_properties(lcm::lcm PROPERTIES IMPORTED_LOCATION ${LCM_LIBRARY}
                                          INTERFACE_INCLUDE_DIRECTORIES ${LCM_INCLUDE_DIR})

# TurboJPEG through libjpeg-turbo's CMake package.
find_package(libjpeg-turbo REQUIRED)
if(TARGET libjpeg-turbo::turbojpeg)
  set(AREOMAP_TURBOJPEG libjpeg-turbo::turbojpeg)
else()
  set(AREOMAP_TURBOJPEG libjpeg-turbo::turbojpeg-static)
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
