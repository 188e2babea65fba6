# bench_gpu_rasterize: the Vulkan rasterizer against the CPU kernel (built with the GPU path only).
if(TARGET gradraster_vulkan)
  add_executable(bench_gpu_rasterize ${CMAKE_CURRENT_SOURCE_DIR}/gpu_rasterize.cpp ${CMAKE_CURRENT_SOURCE_DIR}/mesh_framing.cpp)
  target_link_libraries(bench_gpu_rasterize PRIVATE gradraster::gradraster gradraster::vulkan benchmark::benchmark
                        gradraster_example_common)
endif()
# bench_gpu_texture: Vulkan texture lookups (forward, adjoint) against the CPU kernel.
if(TARGET gradraster_vulkan)
  add_executable(bench_gpu_texture ${CMAKE_CURRENT_SOURCE_DIR}/gpu_texture.cpp)
  target_link_libraries(bench_gpu_texture PRIVATE gradraster::gradraster gradraster::vulkan benchmark::benchmark)
endif()
# bench_gpu_op_chain: the ops' rasterize -> interpolate -> antialias -> backward on a backend.
if(TARGET gradraster_vulkan)
  add_executable(bench_gpu_op_chain ${CMAKE_CURRENT_SOURCE_DIR}/gpu_op_chain.cpp ${CMAKE_CURRENT_SOURCE_DIR}/mesh_framing.cpp)
  target_link_libraries(bench_gpu_op_chain PRIVATE gradraster::gradraster gradraster::vulkan benchmark::benchmark
                        gradraster_example_common)
endif()
# bench_gpu_texture_op: the texture op's forward + backward on a Vulkan backend (what the device uploads).
if(TARGET gradraster_vulkan)
  add_executable(bench_gpu_texture_op ${CMAKE_CURRENT_SOURCE_DIR}/gpu_texture_op.cpp)
  target_link_libraries(bench_gpu_texture_op PRIVATE gradraster::gradraster gradraster::vulkan)
endif()
