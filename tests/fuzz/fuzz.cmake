# libFuzzer targets fuzz_obj, fuzz_image, fuzz_raster and fuzz_shapes (GRADRASTER_FUZZ=ON, clang only).
# Included from the top-level CMakeLists.txt before the library is defined:
# everything is compiled with -fsanitize=fuzzer-no-link plus ASan and UBSan
# (coverage for the fuzzer, reports for bugs), and only the fuzz programs
# link the libFuzzer driver (-fsanitize=fuzzer). The bodies live in
# fuzz_targets.cpp, which the test binary also compiles to replay the seed
# corpus (test_fuzz_corpus.cpp). Run e.g.
#   build-san/tests/fuzz/fuzz_obj -runs=1000000 <copy of tests/fuzz/corpus/obj>
option(GRADRASTER_FUZZ "Build the libFuzzer targets (requires clang)" OFF)

if(GRADRASTER_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "GRADRASTER_FUZZ needs clang (configure with -DCMAKE_CXX_COMPILER=clang++), "
                        "found ${CMAKE_CXX_COMPILER_ID}")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)

  # Link items resolve at generate time, so the library may be defined after
  # this file is included.
  set(GRADRASTER_FUZZ_DIR ${CMAKE_CURRENT_LIST_DIR})
  add_library(gradraster_fuzz_bodies STATIC ${GRADRASTER_FUZZ_DIR}/fuzz_targets.cpp)
  target_include_directories(gradraster_fuzz_bodies PUBLIC ${GRADRASTER_FUZZ_DIR}/..)
  target_link_libraries(gradraster_fuzz_bodies PUBLIC gradraster::gradraster)
  foreach(name obj image raster shapes)
    add_executable(fuzz_${name} ${GRADRASTER_FUZZ_DIR}/fuzz_${name}_main.cc)
    target_link_libraries(fuzz_${name} PRIVATE gradraster_fuzz_bodies)
    target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
    set_target_properties(fuzz_${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/fuzz)
  endforeach()
  # Writes the raster seed corpus (a plain program, no libFuzzer driver).
  add_executable(fuzz_make_raster_seeds ${GRADRASTER_FUZZ_DIR}/make_raster_seeds.cc)
  target_link_libraries(fuzz_make_raster_seeds PRIVATE gradraster_fuzz_bodies)
  set_target_properties(fuzz_make_raster_seeds PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/fuzz)
endif()
