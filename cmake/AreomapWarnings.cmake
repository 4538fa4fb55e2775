# Warnings as errors on project code only (third-party headers come in as SYSTEM includes). The fuzz preset
# (clang) turns -Werror off: clang warns about things gcc does not, and the fuzz build is not where new code
# is vetted.
option(AREOMAP_WARNINGS_AS_ERRORS "-Werror on project code" ON)
add_library(areomap_warnings INTERFACE)
target_compile_options(areomap_warnings INTERFACE -Wall -Wextra -Wpedantic)
if(AREOMAP_WARNINGS_AS_ERRORS)
  target_compile_options(areomap_warnings INTERFACE -Werror)
endif()

# areomap_folder_library(NAME [DEPS public deps...] [PRIVATE_DEPS ...]) -- one library per folder.
# Sources are the folder's *.cpp files (CONFIGURE_DEPENDS: a new file needs no CMake edit); a folder with
# headers only becomes an INTERFACE library. Includes are rooted at the source tree:
# #include "firmware_core/camera/CameraModel.hpp".
function(areomap_folder_library name)
  cmake_parse_arguments(L "" "" "DEPS;PRIVATE_DEPS" ${ARGN})
  file(GLOB _srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  if(_srcs)
    add_library(${name} STATIC ${_srcs})
    target_link_libraries(${name} PRIVATE areomap_warnings ${L_PRIVATE_DEPS} PUBLIC ${L_DEPS})
    target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  else()
    add_library(${name} INTERFACE)
    target_link_libraries(${name} INTERFACE ${L_DEPS})
    target_include_directories(${name} INTERFACE ${PROJECT_SOURCE_DIR})
  endif()
endfunction()

# areomap_tool(NAME SOURCES... LIBS ...) -- a command-line tool built into ${CMAKE_BINARY_DIR}/bin.
function(areomap_tool name)
  cmake_parse_arguments(T "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  target_link_libraries(${name} PRIVATE areomap_warnings ${T_LIBS})
endfunction()
