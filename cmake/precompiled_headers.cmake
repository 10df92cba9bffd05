# Precompiled headers: most of a translation unit's compile time here is spent parsing the
# standard library, Eigen and OpenCV (measured: 3.5 s of loop_detector.cpp's 14 s). Each of these
# is parsed once per build instead of once per file. GCC refuses a header built with other code
# generation flags, so there are three: one shared by the libraries (-fPIC), one by the programs
# and tests, and the core's own (OpenMP defines _OPENMP). GCC only: it falls back to parsing, with
# -Winvalid-pch saying why, where a flag differs; clang stops instead (the sanitizer and fuzzer
# builds use clang).
# Included last, so that every target of this directory is seen.
option(LLC_PRECOMPILED_HEADERS "Precompile the standard library, Eigen and OpenCV headers" ON)
if(NOT LLC_PRECOMPILED_HEADERS OR NOT CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  return()
endif()

set(LLC_PRECOMPILED
  <algorithm> <array> <atomic> <cmath> <cstdint> <functional> <map> <memory> <mutex>
  <optional> <set> <string> <thread> <unordered_map> <utility> <vector>
  <Eigen/Core> <Eigen/Geometry> <opencv2/core.hpp> <opencv2/imgproc.hpp>)

get_property(llc_targets DIRECTORY PROPERTY BUILDSYSTEM_TARGETS)
set(llc_pch_source ${CMAKE_CURRENT_BINARY_DIR}/precompiled_headers.cpp)
file(WRITE ${llc_pch_source} "// The precompiled headers' own translation unit.\n")
foreach(kind shared program)
  add_library(llc_pch_${kind} OBJECT ${llc_pch_source})
  target_link_libraries(llc_pch_${kind} PRIVATE ${OpenCV_LIBS} Eigen3::Eigen)
  target_include_directories(llc_pch_${kind} SYSTEM PRIVATE ${OpenCV_INCLUDE_DIRS})
  target_precompile_headers(llc_pch_${kind} PRIVATE ${LLC_PRECOMPILED})
endforeach()
set_target_properties(llc_pch_shared PROPERTIES POSITION_INDEPENDENT_CODE ON)
set_target_properties(llc_pch_program PROPERTIES POSITION_INDEPENDENT_CODE OFF)

foreach(target ${llc_targets})
  get_target_property(type ${target} TYPE)
  get_target_property(links ${target} LINK_LIBRARIES)
  if(links AND "OpenMP::OpenMP_CXX" IN_LIST links)
    # OpenMP defines _OPENMP, which a header built without it must not see: a header of its own.
    target_precompile_headers(${target} PRIVATE ${LLC_PRECOMPILED})
  elseif(type STREQUAL "SHARED_LIBRARY" OR type STREQUAL "MODULE_LIBRARY")
    target_precompile_headers(${target} REUSE_FROM llc_pch_shared)
  elseif(type STREQUAL "EXECUTABLE")
    target_precompile_headers(${target} REUSE_FROM llc_pch_program)
  else()
    continue()
  endif()
  # Where GCC falls back to parsing the headers, a target that uses neither library finds them.
  target_include_directories(${target} SYSTEM PRIVATE ${OpenCV_INCLUDE_DIRS} ${EIGEN3_INCLUDE_DIR})
endforeach()
