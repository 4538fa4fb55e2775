# Who may include whom (DESIGN.md "Layout", README "Layout"), checked over the #include lines of every .hpp
# and .cpp under firmware_core/, platform/, msgs/ and ground/ of ROOT (CTest: layering, layering_self_test):
#
#   cmake -DROOT=<source dir> -P CheckLayering.cmake      exit 0 when every include is allowed, else 1 with
#                                                          one line per include that breaks a rule
#   cmake -DSELF_TEST=<empty dir> -P CheckLayering.cmake  plants a tree with known breaks in that folder and
#                                                          checks that exactly those are found
#
# Project includes are the quoted ones naming a source folder (firmware_core/, platform/, msgs/, ground/,
# tests/) or a generated message type (areomap/). A file's rule is that of the longest folder prefix below.
# Not checked here: the dependencies among camera, adjust, match and dem inside the core.
cmake_minimum_required(VERSION 3.20)

set(_project_roots firmware_core/ platform/ msgs/ ground/ tests/ areomap/)
set(_core firmware_core/base/ firmware_core/camera/ firmware_core/adjust/ firmware_core/match/ firmware_core/dem/)
# Folder prefix -> the include prefixes allowed there. base is the bottom layer: the rover's status codes,
# capacities, fixed containers and Eigen types, with nothing of the project below it.
set(_rule_firmware_core/base/ firmware_core/base/)
# The core computes only: no messages, no OS edge.
foreach(_f camera adjust match dem)
  set(_rule_firmware_core/${_f}/ ${_core})
endforeach()
set(_rule_firmware_core/node/ firmware_core/ platform/ msgs/ areomap/)
set(_rule_platform/ platform/ firmware_core/base/)
set(_rule_msgs/ msgs/ areomap/ firmware_core/base/)
# Message <-> model conversion: the camera models too, and nothing of the rover pipeline.
set(_rule_msgs/adapters/ msgs/ areomap/ firmware_core/base/ firmware_core/camera/)
# The ground reuses the core, the platform and the messages, but not the rover's pipeline (firmware_core/node).
set(_rule_ground/ ground/ ${_core} platform/ msgs/ areomap/)
# One way through the ground's stages: the node (the stream, its traverse, the manifest) calls the pass and
# the traverse; the traverse calls the pass; nothing calls back (the pass returns its data, SitePass). The
# folders below them are listed: a new ground folder joins this list or stays out of the pass's reach.
set(_ground_below_traverse ground/adjust/ ground/cli/ ground/dataset/ ground/dem/ ground/dense/ ground/ingest/
                           ground/io/ ground/ortho/ ground/pack/ ground/pass/ ground/products/ ground/raster/
                           ground/sim/ ground/ties/)
set(_rule_ground/pass/ ${_ground_below_traverse} ${_core} platform/ msgs/ areomap/)
set(_rule_ground/traverse/ ${_ground_below_traverse} ground/traverse/ ${_core} platform/ msgs/ areomap/)
set(_rule_prefixes firmware_core/base/ firmware_core/camera/ firmware_core/adjust/ firmware_core/match/
                   firmware_core/dem/ firmware_core/node/ platform/ msgs/adapters/ msgs/ ground/pass/
                   ground/traverse/ ground/)
# Third-party headers that never appear on the rover side (firmware_core, platform, msgs).
set(_rover_forbidden_system opencv2/ gdal ceres/ nlohmann/)

# _first_prefix(TEXT OUT_VAR PREFIXES...): OUT_VAR = the first of PREFIXES that TEXT starts with, else "".
function(_first_prefix text out_var)
  foreach(_prefix IN LISTS ARGN)
    string(FIND "${text}" "${_prefix}" _at)
    if(_at EQUAL 0)
      set(${out_var} ${_prefix} PARENT_SCOPE)
      return()
    endif()
  endforeach()
  set(${out_var} "" PARENT_SCOPE)
endfunction()

# _check_tree(ROOT OUT_VAR): OUT_VAR = the list of breaks, each "file: includes X (what the rule allows)".
function(_check_tree root out_var)
  set(_breaks)
  file(GLOB_RECURSE _files RELATIVE ${root} ${root}/firmware_core/*.hpp ${root}/firmware_core/*.cpp
       ${root}/platform/*.hpp ${root}/platform/*.cpp ${root}/msgs/*.hpp ${root}/msgs/*.cpp ${root}/ground/*.hpp
       ${root}/ground/*.cpp)
  list(SORT _files)
  foreach(_file IN LISTS _files)
    _first_prefix("${_file}" _rule ${_rule_prefixes})
    if(_rule STREQUAL "")
      continue()
    endif()
    file(STRINGS ${root}/${_file} _lines REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"]")
    foreach(_line IN LISTS _lines)
      string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*([<\"])([^>\"]*)[>\"].*" "\\1;\\2" _inc "${_line}")
      list(GET _inc 0 _kind)
      list(GET _inc 1 _path)
      if(_kind STREQUAL "<")
        _first_prefix("${_path}" _sys ${_rover_forbidden_system})
        string(FIND "${_rule}" "ground/" _ground_at)
        if(NOT _ground_at EQUAL 0 AND NOT _sys STREQUAL "")
          list(APPEND _breaks "${_file}: includes <${_path}> (no ${_sys} on the rover side)")
        endif()
        continue()
      endif()
      _first_prefix("${_path}" _project ${_project_roots})
      _first_prefix("${_path}" _allowed ${_rule_${_rule}})
      if(NOT _project STREQUAL "" AND _allowed STREQUAL "")
        string(REPLACE ";" " " _list "${_rule_${_rule}}")
        list(APPEND _breaks "${_file}: includes \"${_path}\" (${_rule} may include: ${_list})")
      endif()
    endforeach()
  endforeach()
  set(${out_var} "${_breaks}" PARENT_SCOPE)
endfunction()

if(DEFINED SELF_TEST)
  # One allowed and one forbidden include per rule that the source tree relies on.
  set(_t ${SELF_TEST})
  file(REMOVE_RECURSE ${_t})
  file(WRITE ${_t}/firmware_core/base/Ok.hpp "#include <cstdint>\n#include \"firmware_core/base/Status.hpp\"\n")
  file(WRITE ${_t}/firmware_core/base/Bad.hpp "#include \"firmware_core/camera/CameraModel.hpp\"\n")
  file(WRITE ${_t}/firmware_core/dem/Bad.cpp "#include \"firmware_core/dem/CoarseDem.hpp\"\n#include \"platform/Clock.hpp\"\n")
  file(WRITE ${_t}/firmware_core/match/Bad.cpp "#include <opencv2/core.hpp>\n")
  file(WRITE ${_t}/platform/posix/Bad.cpp "#include <lcm/lcm.h>\n#include \"firmware_core/adjust/Network.hpp\"\n")
  file(WRITE ${_t}/msgs/Bad.cpp "#include \"areomap/stereo_pair_t.hpp\"\n#include \"firmware_core/camera/CameraModel.hpp\"\n")
  file(WRITE ${_t}/msgs/adapters/Ok.cpp "#include \"firmware_core/camera/CameraModel.hpp\"\n#include \"msgs/MessageCheck.hpp\"\n")
  file(WRITE ${_t}/msgs/adapters/Bad.cpp "#include \"firmware_core/node/RoverNode.hpp\"\n")
  file(WRITE ${_t}/ground/node/Ok.cpp "#include <opencv2/core.hpp>\n#include \"firmware_core/adjust/FastAdjuster.hpp\"\n#include \"msgs/adapters/MessageAdapters.hpp\"\n")
  file(WRITE ${_t}/ground/node/Bad.cpp "#include \"ground/node/Ok.hpp\"\n#include \"firmware_core/node/MessageAdapters.hpp\"\n")
  file(WRITE ${_t}/ground/node/Ok2.cpp "#include \"ground/pass/GroundPass.hpp\"\n#include \"ground/traverse/TraverseRun.hpp\"\n")
  file(WRITE ${_t}/ground/pass/Ok.cpp "#include <nlohmann/json.hpp>\n#include \"ground/products/Products.hpp\"\n#include \"ground/ties/TieRunner.hpp\"\n")
  file(WRITE ${_t}/ground/pass/Bad.cpp "#include \"ground/pass/Ok.hpp\"\n#include \"ground/node/StreamCollector.hpp\"\n")
  file(WRITE ${_t}/ground/pass/Bad2.hpp "#include \"ground/traverse/TraverseRun.hpp\"\n")
  file(WRITE ${_t}/ground/traverse/Ok.cpp "#include \"ground/pass/GroundPass.hpp\"\n#include \"ground/traverse/SiteDatum.hpp\"\n")
  file(WRITE ${_t}/ground/traverse/Bad.cpp "#include \"ground/traverse/Ok.hpp\"\n#include \"ground/node/GroundNode.hpp\"\n")
  _check_tree(${_t} _found)
  set(_expected firmware_core/base/Bad.hpp firmware_core/dem/Bad.cpp firmware_core/match/Bad.cpp
                platform/posix/Bad.cpp msgs/Bad.cpp msgs/adapters/Bad.cpp ground/node/Bad.cpp ground/pass/Bad.cpp
                ground/pass/Bad2.hpp ground/traverse/Bad.cpp)
  list(LENGTH _found _count)
  list(LENGTH _expected _want)
  set(_fail FALSE)
  foreach(_e IN LISTS _expected)
    string(FIND "${_found}" "${_e}:" _at)
    if(_at LESS 0)
      message("CheckLayering self-test: the planted break in ${_e} was not found")
      set(_fail TRUE)
    endif()
  endforeach()
  if(NOT _count EQUAL _want)
    string(REPLACE ";" "\n  " _all "${_found}")
    message("CheckLayering self-test: ${_count} breaks found, ${_want} planted:\n  ${_all}")
    set(_fail TRUE)
  endif()
  if(_fail)
    message(FATAL_ERROR "CheckLayering self-test failed")
  endif()
  message("CheckLayering self-test: all ${_want} planted breaks found, no allowed include flagged")
  return()
endif()

if(NOT DEFINED ROOT)
  message(FATAL_ERROR "usage: cmake -DROOT=<source dir> -P CheckLayering.cmake (or -DSELF_TEST=<dir>)")
endif()
_check_tree(${ROOT} _found)
list(LENGTH _found _count)
if(_count GREATER 0)
  string(REPLACE ";" "\n  " _all "${_found}")
  message("${_count} include(s) break the layering:\n  ${_all}")
  message(FATAL_ERROR "layering check failed")
endif()
message("layering: every include of firmware_core, platform, msgs and ground is allowed")
