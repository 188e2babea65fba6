// The dispatch scheme (dispatch() in kernels.cpp): one invocation per item,
// WORKGROUP_SIZE per workgroup (256 unless the shader defines it first; the
// host passes the same), in rows of at most 65535 workgroups stacked in y,
// since one dimension holds at most 65535 (Vulkan's guaranteed minimum).
// Every shader includes this first: it declares the workgroup size itself, and
// the index does not read gl_WorkGroupSize, which glslang silently takes as 1
// above the shader's layout line (the cause of issue 33's wrong results beyond
// 2^24 items: the second row took items 65535 + x, not 65535 x 256 + x).
#ifndef WORKGROUP_SIZE
#define WORKGROUP_SIZE 256
#endif
layout(local_size_x = WORKGROUP_SIZE) in;

// The invocation's item: (row * workgroups per row + workgroup) * size + lane.
// Invocations past 2^31 (the last row's tail) get INT_MAX, at or beyond any
// item count, so `if (i >= count) return;` keeps them out.
int linear_id() {
  uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
  uint id = group * uint(WORKGROUP_SIZE) + gl_LocalInvocationIndex;
  return group < 0x80000000u / uint(WORKGROUP_SIZE) ? int(id) : 0x7fffffff;
}
