"""nvdiffrast.torch's interface on the CPU: `import gradraster.torch as dr`,
then `glctx = dr.RasterizeCpuContext()` where nvdiffrast code creates a
RasterizeCudaContext, and CPU tensors."""
from .ops import (RasterizeCpuContext, rasterize, DepthPeeler, interpolate, texture, texture_construct_mip,
                  antialias, antialias_construct_topology_hash)

__all__ = ['RasterizeCpuContext', 'rasterize', 'DepthPeeler', 'interpolate', 'texture', 'texture_construct_mip',
           'antialias', 'antialias_construct_topology_hash']
