# The hand-fused Blinn-Phong and textured passes (issue 17): a static library for bench_fused
# and the test that checks it against the tape's gradients.
if(NOT TARGET gradraster_fused_baseline)
  add_library(gradraster_fused_baseline STATIC ${CMAKE_CURRENT_LIST_DIR}/fused_blinn_phong.cpp
                                               ${CMAKE_CURRENT_LIST_DIR}/fused_textured.cpp)
  target_include_directories(gradraster_fused_baseline PUBLIC ${CMAKE_CURRENT_LIST_DIR})
  target_link_libraries(gradraster_fused_baseline PUBLIC gradraster::gradraster)
  # Square roots without errno, and selections that may be computed either way
  # (no trapping floating point), so the per-lane loops vectorize. Neither
  # changes a value.
  target_compile_options(gradraster_fused_baseline PRIVATE -fno-math-errno -fno-trapping-math)
endif()
