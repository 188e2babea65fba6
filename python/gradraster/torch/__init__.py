"""nvdiffrast.torch's interface on the CPU: `import gradraster.torch as dr`,
then `glctx = dr.RasterizeCpuContext()` where nvdiffrast code creates a
RasterizeCudaContext, and CPU tensors. The names RasterizeCudaContext and
RasterizeGLContext exist too; constructing either gives a CPU context.
RasterizeVulkanContext() runs the ops on a Vulkan device (docs/python.md, "Vulkan")."""
import re as _re

import torch as _torch

# The module does not link libtorch: any torch from 1.13 on works (tested:
# Debian's 1.13, docs/python.md "Installing").
_torch_version = _re.match(r'(\d+)\.(\d+)', str(_torch.__version__))
if _torch_version is None or tuple(map(int, _torch_version.groups())) < (1, 13):
    raise ImportError(f"gradraster.torch needs torch >= 1.13, found torch {_torch.__version__}")

from .. import _core as _gradraster_core
from .ops import (RasterizeCpuContext, RasterizeVulkanContext, RasterizeCudaContext, RasterizeGLContext, rasterize,
                  DepthPeeler, interpolate, texture, texture_construct_mip, antialias, antialias_construct_topology_hash,
                  visibility_antialias)

__all__ = ['RasterizeCpuContext', 'RasterizeVulkanContext', 'RasterizeCudaContext', 'RasterizeGLContext', 'rasterize',
           'DepthPeeler', 'interpolate', 'texture', 'texture_construct_mip', 'antialias', 'antialias_construct_topology_hash',
           'visibility_antialias']

# Fresh pages are expensive, and every iteration of a fitting loop allocates
# image- and texture-sized tensors: keep freed memory for reuse (docs/python.md,
# "Memory"; GRADRASTER_MALLOC_DEFAULTS=1 keeps glibc's defaults).
_gradraster_core.keep_freed_memory()
