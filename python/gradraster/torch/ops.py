"""nvdiffrast.torch's interface on the CPU, on gradraster's kernels.

Every op is a torch.autograd.Function whose forward and backward run
gradraster's C++ kernels directly on the tensors' memory (float32 or float64,
CPU, contiguous). Conventions are nvdiffrast's (docs/python.md): rast is
[minibatch, height, width, 4] = (u, v, z/w, triangle_id + 1) with u, v the
perspective-correct barycentrics of the triangle's vertices 0 and 1, row 0 at
clip-space y = -1 (the bottom of the image), pixel centres at half-integers.

Threads: each call runs on torch.get_num_threads() threads; results and
gradients are bit-identical for any thread count.

The checks here give nvdiffrast's error messages; _core checks every shape,
dtype and layout again itself (python/src/array.h), so none lives only here.
"""
import numbers

import torch
from torch.autograd.function import once_differentiable

from .. import _core
from ._origin import kept_gbuffers, origin, record_origin
from ._resident import KeptGBuffers, KeptTextures
from ._topologies import KeptTopologies
from ._versions import version

_MAX_SIDE = _core.MAX_SIDE  # pixels per side (the rasterizer's limit, raster::kMaxSide)
_MAX_FLOAT32_IDS = 1 << 24  # float32 holds every triangle id + 1 exactly up to here


def _threads():
    """torch's thread count. torch.set_num_threads takes any count, the kernels
    at most _core.MAX_THREADS (1024): a larger count means all hardware threads (0)."""
    n = torch.get_num_threads()
    return n if n <= _core.MAX_THREADS else 0


# ----------------------------------------------------------------------------
# Tensors for _core. _core takes tensors, never addresses: each function views
# its tensor arguments through DLPack when the call starts and holds them
# until its kernels are done, checking their device, dtype, layout and shapes
# itself (python/src/array.h). Tensors that require grad do not export
# DLPack, so they go as detached aliases of the same memory.

def _d(t):
    """t, detached (None stays None): what _core takes."""
    return None if t is None else t.detach()


def _saved(ctx):
    """ctx.saved_tensors, each contiguous (None stays None): a saved_tensors_hooks pair (offloading, compression)
    may give them back with the same values in another memory layout."""
    return [None if t is None else t.contiguous() for t in ctx.saved_tensors]


def _fingerprint(t):
    """A 64-bit fingerprint of contiguous t's bytes, the same for any thread count (python/src/fingerprint.h)."""
    return _core.fingerprint(t.detach(), _threads())


# ----------------------------------------------------------------------------
# Input checks: each names the argument and the problem.

def _tensor(name, x, dims=None, dtypes=None):
    if not isinstance(x, torch.Tensor):
        raise TypeError(f"'{name}' must be a torch.Tensor, got {type(x).__name__}")
    if x.device.type != 'cpu':
        raise ValueError(f"'{name}' is on {x.device}; gradraster runs on the CPU: pass {name}.cpu()")
    if dims is not None and x.dim() not in dims:
        want = ' or '.join(f'{d}D' for d in dims)
        raise ValueError(f"'{name}' must be {want}, got shape {list(x.shape)}")
    if dtypes is not None and x.dtype not in dtypes:
        want = ' or '.join(str(d) for d in dtypes)
        raise TypeError(f"'{name}' must have dtype {want}, got {x.dtype}")
    if not x.is_contiguous():
        raise ValueError(f"'{name}' is not contiguous; pass {name}.contiguous()")
    return x


_FLOATS = (torch.float32, torch.float64)


def _float(name, x, dims=None, like=None):
    _tensor(name, x, dims, _FLOATS)
    if like is not None and x.dtype != like[1].dtype:
        raise TypeError(f"'{name}' has dtype {x.dtype} but '{like[0]}' has {like[1].dtype}; use one float dtype")
    return x


def _tri(tri):
    _tensor('tri', tri, (2,), (torch.int32,))
    if tri.shape[1] != 3:
        raise ValueError(f"'tri' must have shape [num_triangles, 3], got {list(tri.shape)}")
    return tri


def _rast(name, rast, like=None):
    _float(name, rast, (4,), like=like)
    if rast.shape[3] != 4:
        raise ValueError(f"'{name}' must have shape [minibatch_size, height, width, 4], got {list(rast.shape)}")
    return rast


def _integer(v):
    """v as an int if it is an integer (a Python or numpy integer, or a 0-dim integer tensor on the CPU, which
    nvdiffrast's C++ arguments take too), else None; True and False are not integers here."""
    if isinstance(v, torch.Tensor):
        integral = v.dtype != torch.bool and not v.is_floating_point() and not v.is_complex()
        return int(v.item()) if v.dim() == 0 and integral and v.device.type == 'cpu' else None
    return None if isinstance(v, bool) or not isinstance(v, numbers.Integral) else int(v)


def _real(v):
    """v as a float if it is a real number (a Python or numpy number, or a 0-dim real tensor on the CPU), else
    None; True and False are not numbers here."""
    if isinstance(v, torch.Tensor):
        real = v.dtype != torch.bool and not v.is_complex()
        return float(v.item()) if v.dim() == 0 and real and v.device.type == 'cpu' else None
    return None if isinstance(v, bool) or not isinstance(v, numbers.Real) else float(v)


def _resolution(resolution):
    try:
        h, w = resolution
    except (TypeError, ValueError):
        raise ValueError(f"'resolution' must be (height, width), got {resolution!r}") from None
    sides = []
    for name, v in (('height', h), ('width', w)):
        side = _integer(v)
        if side is None:
            raise TypeError(f"'resolution' {name} must be an integer, got {v!r}")
        if not 1 <= side <= _MAX_SIDE:
            raise ValueError(f"'resolution' {name} = {side} is outside 1..{_MAX_SIDE}")
        sides.append(side)
    return tuple(sides)


def _mesh(pos, tri, ranges, op):
    """_core's mesh arguments (pos, tri, ranges) for nvdiffrast's instanced ([B, N, 4] pos) or range ([N, 4] pos +
    ranges) mode."""
    _float('pos', pos, (2, 3))
    _tri(tri)
    if pos.shape[-1] != 4:
        raise ValueError(f"'pos' must have shape [..., num_vertices, 4], got {list(pos.shape)}")
    if pos.dtype == torch.float32 and tri.shape[0] >= _MAX_FLOAT32_IDS:
        raise ValueError(f"{op}: {tri.shape[0]} triangles are more than float32 rast can number exactly "
                         f"({_MAX_FLOAT32_IDS - 1}); use float64")
    if pos.dim() == 3:
        if pos.shape[0] < 1:
            raise ValueError(f"instanced mode - 'pos' must have shape [>0, num_vertices, 4], got {list(pos.shape)}")
        return _d(pos), _d(tri), []
    if ranges is None:
        raise ValueError("range mode - 'pos' is [num_vertices, 4], so 'ranges' [minibatch_size, 2] is required "
                         "(or give pos a minibatch axis: [1, num_vertices, 4])")
    _tensor('ranges', ranges, (2,), (torch.int32,))
    if ranges.shape[0] < 1 or ranges.shape[1] != 2:
        raise ValueError(f"range mode - 'ranges' must have shape [>0, 2], got {list(ranges.shape)}")
    return _d(pos), _d(tri), [tuple(r) for r in ranges.tolist()]


# ----------------------------------------------------------------------------
# Context and rasterize.

class RasterizeCpuContext:
    """The CPU counterpart of nvdiffrast's RasterizeCudaContext: owns the
    rasterizer's scratch buffers, reused across calls. `device` is accepted
    for compatibility and must be None or a CPU device."""

    def __init__(self, device=None):
        _check_cpu_device(type(self).__name__, device)
        self.cpp_wrapper = _core.Context()
        self.active_depth_peeler = None
        self.output_db = True
        self.device = torch.device('cpu')


def _check_cpu_device(context, device):
    try:
        cpu = device is None or torch.device(device).type == 'cpu'
    except (TypeError, RuntimeError):
        raise ValueError(f"{context}: 'device' must be None or a torch device, got {device!r}") from None
    if not cpu:
        raise ValueError(f"{context}: 'device' is {device}, but gradraster runs on the CPU: pass device=None or "
                         f"'cpu' (and CPU tensors)")


class RasterizeVulkanContext(RasterizeCpuContext):
    """A context whose ops run on a Vulkan device (any vendor's GPU, or Mesa's
    lavapipe on the CPU), with CPU tensors in and out: accepted by every
    function that takes a context. On the device, for float32, forward and
    backward: rasterize (depth peeling included; the G-buffer is the CPU
    context's bit for bit), and interpolate, antialias, visibility_antialias
    and texture (2D and cube maps) when their inputs come from this context:
    interpolate and the antialiases when `rast` is the very tensor rasterize
    returned, texture when `uv` is the very tensor interpolate returned for
    such a rast. Any other tensor (a slice, a copy, one computed by torch) and
    float64 run on the CPU kernels (docs/python.md, "Vulkan").
    Values match the CPU kernels' within 1e-6 relative and gradients within
    1e-5 of the largest, bit-identical run to run (docs/gpu.md).
    rasterize keeps each image's G-buffer on the device, where interpolate,
    antialias and the rasterize backward read it while rast, rast_db, pos and
    tri are unchanged (else they upload them): `frames` G-buffers at once
    (None: as many as the largest minibatch rasterized, at least 4; each
    takes about 300 bytes per pixel of device memory, and one more frame
    serves the uploads). `residency` counts them.
    texture keeps the texels on the device too, from its forward to its
    backward and across calls: the last `textures` textures looked up (tex,
    and a prebuilt or user mip stack: the very tensors, not written in place
    since by torch's count, with the same bytes by a fingerprint that sees
    writes through .data or a numpy view too; 0: none kept across calls) are
    read there again instead of uploaded.
    `texture_residency` counts them.
    The device is the first discrete GPU, else any GPU, else a CPU device;
    the environment variable GRADRASTER_VULKAN_DEVICE (part of the device's
    name) chooses another. Raises RuntimeError, saying why, when there is none.
    `device` must be None or a CPU device: tensors stay on the CPU."""

    def __init__(self, device=None, frames=None, textures=4):
        super().__init__(device)
        if frames is not None and (isinstance(frames, bool) or not isinstance(frames, numbers.Integral)):
            raise TypeError(f"RasterizeVulkanContext: 'frames' must be None or an integer, got {frames!r}")
        if isinstance(textures, bool) or not isinstance(textures, numbers.Integral):
            raise TypeError(f"RasterizeVulkanContext: 'textures' must be an integer, got {textures!r}")
        if textures < 0:
            raise ValueError(f"RasterizeVulkanContext: 'textures' must be >= 0, got {textures}")
        self.cpp_wrapper = _core.Context.vulkan(None if frames is None else int(frames))
        self.kept_textures = KeptTextures(int(textures), _fingerprint)

    @property
    def vulkan_device(self):
        """The Vulkan device's name, e.g. 'NVIDIA H200' or 'llvmpipe (LLVM 15.0.6, 256 bits)'."""
        return self.cpp_wrapper.device_name

    @property
    def device_calls(self):
        """How many per-image kernel calls (forward or backward, of any op) have run on the device: a program can
        check that its interpolate, antialias and texture calls found this context (docs/python.md, "Vulkan")."""
        return self.cpp_wrapper.device_calls

    @property
    def residency(self):
        """What the device did with rasterize's G-buffers so far, a dict: 'gbuffers' made and kept there,
        'resident_calls' (interpolate, antialias, rasterize backward, per image) that read a kept one, 'uploads'
        (such calls that uploaded rast instead: changed tensors, or let go), 'frames' made, 'topology_uploads'
        (antialias calls, forward or backward, per image, that uploaded the edge topology: each frame keeps the last
        one), 'topology_bytes', 'triangle_uploads' (rasterize calls, per image, that uploaded tri, and G-buffer
        uploads that did: each frame keeps the last triangle list it uploaded, so an unchanged tri goes up once per
        frame; in range mode antialias on a range of some of tri also uploads the whole tri once per frame),
        'triangle_bytes', 'antialias_reused' (antialias backward calls, per image, that read the pairs their
        forward kept on the device instead of recomputing them), 'interpolate_reused' (interpolate backward
        calls, per image, that read their forward's attributes there instead of interpolating again) and
        'deferred_calls' (per-image calls of rasterize, interpolate and antialias, forward or backward, submitted to
        the device without waiting: a minibatch's images run there while the host prepares the next, and the
        call returns once all are done) (docs/python.md, "Vulkan")."""
        return dict(self.cpp_wrapper.residency)

    @property
    def texture_residency(self):
        """What the device did with the textures' texels so far, a dict: 'uploads' (texture calls, per image, that
        uploaded them), 'upload_bytes', 'resident_calls' (calls that read the copy kept on the device: a texture
        backward reads its forward's, a later call on an unchanged texture the earlier's), 'kept' and 'kept_bytes'
        (the copies the device keeps now, of every context on it), 'textures' (those this context would hand back:
        at most its `textures`) (docs/gpu.md, "What stays resident")."""
        out = dict(self.cpp_wrapper.texture_residency)
        out['textures'] = len(self.kept_textures)
        return out


# nvdiffrast's two context classes, by name, so that programs that name them
# (in type annotations, isinstance checks or construction) run unchanged:
# constructing either gives a CPU context (docs/python.md).

class RasterizeCudaContext(RasterizeCpuContext):
    """nvdiffrast's RasterizeCudaContext(device=None), here a CPU context."""


class RasterizeGLContext(RasterizeCpuContext):
    """nvdiffrast's RasterizeGLContext(output_db=True, mode='automatic',
    device=None), here a CPU context. output_db=False: rasterize returns an
    empty rast_db ([minibatch, height, width, 0]), as nvdiffrast's does.
    mode='manual' takes set_context() / release_context() calls, which do
    nothing on the CPU."""

    def __init__(self, output_db=True, mode='automatic', device=None):
        super().__init__(device)
        if output_db is not True and output_db is not False:
            raise TypeError(f"RasterizeGLContext: 'output_db' must be True or False, got {output_db!r}")
        if mode not in ('automatic', 'manual'):
            raise ValueError(f"RasterizeGLContext: 'mode' must be 'automatic' or 'manual', got {mode!r}")
        self.output_db, self.mode = output_db, mode

    def set_context(self):
        self._check_manual('set_context')

    def release_context(self):
        self._check_manual('release_context')

    def _check_manual(self, method):
        if self.mode != 'manual':
            raise RuntimeError(f"RasterizeGLContext.{method}() is for mode='manual' (this context is {self.mode!r})")


class _RasterizeFunc(torch.autograd.Function):
    @staticmethod
    def forward(ctx, raster_ctx, pos, tri, resolution, ranges, grad_db, peel, kept):
        mesh = _mesh(pos, tri, ranges, 'rasterize')
        h, w = resolution
        images = pos.shape[0] if pos.dim() == 3 else ranges.shape[0]
        rast = pos.new_empty((images, h, w, 4))
        db = torch.empty_like(rast)
        # A Vulkan context keeps the G-buffers on its device: their handles go to `kept` (a list) and the backward.
        ctx.kept = _core.rasterize_forward(raster_ctx.cpp_wrapper, *mesh, rast, db, peel, _threads())
        kept.append(ctx.kept)
        ctx.save_for_backward(pos, tri, rast)
        ctx.raster_ctx, ctx.ranges, ctx.grad_db = raster_ctx, ranges, grad_db
        return rast, db

    @staticmethod
    @once_differentiable
    def backward(ctx, drast, ddb):
        pos, tri, rast = _saved(ctx)  # autograd refuses these if written in place since: ctx.kept holds
        mesh = _mesh(pos, tri, ctx.ranges, 'rasterize')
        grad_pos = torch.zeros_like(pos)
        _core.rasterize_backward(ctx.raster_ctx.cpp_wrapper, *mesh, _d(rast), _d(drast.contiguous()),
                                 _d(ddb.contiguous()) if ctx.grad_db else None, grad_pos, _threads(), ctx.kept)
        return None, grad_pos, None, None, None, None, None, None


def _check_context(glctx):
    if not isinstance(glctx, RasterizeCpuContext):
        raise TypeError(f"'glctx' must be a RasterizeCpuContext, got {type(glctx).__name__}")


def rasterize(glctx, pos, tri, resolution, ranges=None, grad_db=True):
    """Rasterize triangles (nvdiffrast.torch.rasterize).

    pos: [minibatch, num_vertices, 4] (instanced mode) or [num_vertices, 4]
    with ranges [minibatch, 2] int32 (first triangle, count) (range mode),
    clip-space positions; tri: [num_triangles, 3] int32; resolution:
    (height, width). Returns (rast, rast_db), each [minibatch, height, width,
    4]: rast = (u, v, z/w, triangle_id + 1) (0 everywhere on the background)
    and rast_db = (du/dX, du/dY, dv/dX, dv/dY) in pixels. grad_db: whether
    gradients of rast_db flow to pos.
    """
    _check_context(glctx)
    if grad_db is not True and grad_db is not False:
        raise TypeError(f"'grad_db' must be True or False, got {grad_db!r}")
    if glctx.active_depth_peeler is not None:
        raise RuntimeError("Cannot call rasterize() during depth peeling operation, use rasterize_next_layer() instead")
    resolution = _resolution(resolution)
    return _rasterize(glctx, pos, tri, resolution, ranges, grad_db, None)


def _device(glctx):
    """glctx's _core.Context when its device runs the ops (a RasterizeVulkanContext), else None (the CPU kernels)."""
    return glctx.cpp_wrapper if isinstance(glctx, RasterizeVulkanContext) else None


def _rasterize(glctx, pos, tri, resolution, ranges, grad_db, peel):
    kept = []
    rast, db = _RasterizeFunc.apply(glctx, pos, tri, resolution, ranges, grad_db and glctx.output_db, peel, kept)
    # interpolate and antialias run on its device, reading the G-buffers kept there while these are unchanged.
    handles = kept[0]
    gbuffers = None if handles is None else KeptGBuffers(handles, _fingerprint, rast=rast, rast_db=db, pos=pos,
                                                         tri=tri)
    record_origin(rast, glctx, gbuffers)
    if not glctx.output_db:  # RasterizeGLContext(output_db=False), as nvdiffrast's
        db = db.new_zeros(db.shape[:3] + (0,))
    return rast, db


def _kept(rast, **reads):
    """The handles of the G-buffers rast's rasterize kept on its device if rast and the tensors the call reads
    (name=tensor, as rasterize named them) are unchanged since (_resident.py), else None."""
    kept = kept_gbuffers(rast)
    return kept.handles_for(rast=rast, **reads) if kept is not None else None


def _identity(t):
    """What an in-place change of t alters: its memory, shape, layout or contents (torch's version counter, or for
    an inference tensor, which has none, a fingerprint of its bytes)."""
    if t is None:
        return None
    written = version(t)
    if written is None:
        written = _fingerprint(t) if t.is_contiguous() else None  # not contiguous: its strides differ already
    return t.data_ptr(), tuple(t.shape), t.stride(), t.dtype, t.device, written


class DepthPeeler:
    """Successive depth layers (nvdiffrast.torch.DepthPeeler), as a context
    manager: `with DepthPeeler(glctx, pos, tri, resolution) as peeler:` then
    `rast, rast_db = peeler.rasterize_next_layer()` per layer. Layer k holds,
    per pixel, the nearest surface strictly behind layer k-1's in the
    rasterizer's (depth, triangle id) order, so coplanar faces each appear in
    exactly one layer; after the last surface, layers are empty (all zero)."""

    def __init__(self, glctx, pos, tri, resolution, ranges=None, grad_db=True):
        _check_context(glctx)
        if grad_db is not True and grad_db is not False:
            raise TypeError(f"'grad_db' must be True or False, got {grad_db!r}")
        _mesh(pos, tri, ranges, 'DepthPeeler')
        self.raster_ctx, self.pos, self.tri = glctx, pos, tri
        self.resolution, self.ranges, self.grad_db = _resolution(resolution), ranges, grad_db
        self.state = None
        # Each layer lies behind the one before it, per pixel: the layers are
        # of one scene only if pos, tri and ranges stay what they were.
        self.inputs = {'pos': _identity(pos), 'tri': _identity(tri), 'ranges': _identity(ranges)}

    def __enter__(self):
        if self.raster_ctx is None:
            raise RuntimeError("Cannot re-enter a terminated depth peeling operation")
        if self.raster_ctx.active_depth_peeler is not None:
            raise RuntimeError("Cannot have multiple depth peelers active simultaneously in a rasterization context")
        self.raster_ctx.active_depth_peeler = self
        self.state = _core.PeelState()
        return self

    def __exit__(self, *args):
        self.raster_ctx.active_depth_peeler = None
        self.raster_ctx = self.pos = self.tri = self.ranges = self.state = None
        return None

    def rasterize_next_layer(self):
        """The next layer, as rasterize() returns it."""
        if self.raster_ctx is None or self.raster_ctx.active_depth_peeler is not self:
            raise RuntimeError("rasterize_next_layer() must be called inside 'with DepthPeeler(...) as peeler:'")
        for name, t in (('pos', self.pos), ('tri', self.tri), ('ranges', self.ranges)):
            if _identity(t) != self.inputs[name]:
                raise RuntimeError(f"DepthPeeler: '{name}' was changed in place (resized, moved or written) after the "
                                   f"peeler was created; give the changed tensors to a new DepthPeeler")
        return _rasterize(self.raster_ctx, self.pos, self.tri, self.resolution, self.ranges, self.grad_db, self.state)


# ----------------------------------------------------------------------------
# Interpolate.

def _diff_list(diff_attrs, channels):
    if diff_attrs is None:
        return []
    if isinstance(diff_attrs, str):
        if diff_attrs != 'all':
            raise ValueError(f"'diff_attrs' must be 'all' or a list of attribute indices, got {diff_attrs!r}")
        return list(range(channels))
    indices = diff_attrs.tolist() if isinstance(diff_attrs, torch.Tensor) else diff_attrs
    try:
        indices = iter(indices)
    except TypeError:
        raise TypeError(f"'diff_attrs' must be 'all' or a list of attribute indices, got {diff_attrs!r}") from None
    out = []
    for d in indices:
        if isinstance(d, bool) or not isinstance(d, numbers.Integral):
            raise TypeError(f"'diff_attrs' must hold integers, got {d!r}")
        if not 0 <= d < channels:
            raise ValueError(f"'diff_attrs' index {d} is outside 0..{channels - 1} (attr has {channels} attributes)")
        out.append(int(d))
    return out


def _interpolate_args(attr, rast, tri, rast_db, diff):
    _rast('rast', rast)
    _float('attr', attr, (2, 3), like=('rast', rast))
    _tri(tri)
    images, h, w = rast.shape[:3]
    if attr.dim() == 3 and attr.shape[0] not in (1, images):
        raise ValueError(f"'attr' has minibatch size {attr.shape[0]} but 'rast' has {images} (broadcast needs 1)")
    if rast_db is not None:
        _float('rast_db', rast_db, (4,), like=('rast', rast))
        if rast_db.shape != rast.shape:
            raise ValueError(f"'rast_db' must have rast's shape {list(rast.shape)}, got {list(rast_db.shape)}")
    return _d(attr), _d(rast), _d(tri), _d(rast_db), diff


class _InterpolateFunc(torch.autograd.Function):
    @staticmethod
    def forward(ctx, attr, rast, tri, rast_db, diff, device, kept):
        args = _interpolate_args(attr, rast, tri, rast_db, diff)
        images, h, w = rast.shape[:3]
        out = attr.new_empty((images, h, w, attr.shape[-1]))
        out_da = attr.new_empty((images, h, w, 2 * len(diff)))
        left = _core.interpolate_forward(device, *args, out, out_da if diff else None, _threads(), kept)
        ctx.save_for_backward(attr, rast, tri, rast_db)
        ctx.diff, ctx.device, ctx.kept, ctx.left = diff, device, kept, left  # left: what the device kept
        return out, out_da

    @staticmethod
    @once_differentiable
    def backward(ctx, dy, dda):
        attr, rast, tri, rast_db = _saved(ctx)
        args = _interpolate_args(attr, rast, tri, rast_db, ctx.diff)
        need_attr, need_rast, _, need_db = ctx.needs_input_grad[:4]
        g_attr = torch.zeros_like(attr) if need_attr else None
        g_rast = torch.zeros_like(rast) if need_rast else None
        g_db = torch.zeros_like(rast_db) if need_db and rast_db is not None else None
        _core.interpolate_backward(ctx.device, *args, _d(dy.contiguous()), _d(dda.contiguous()) if ctx.diff else None,
                                   g_attr, g_rast, g_db, _threads(), ctx.kept, ctx.left)
        return g_attr, g_rast, None, g_db, None, None, None


def interpolate(attr, rast, tri, rast_db=None, diff_attrs=None):
    """Interpolate vertex attributes (nvdiffrast.torch.interpolate).

    attr: [num_vertices, num_attributes] or [minibatch (or 1), num_vertices,
    num_attributes]; rast, rast_db: rasterize's outputs; tri as given to
    rasterize. Returns (out [minibatch, height, width, num_attributes],
    out_da [minibatch, height, width, 2 len(diff_attrs)]) with out_da holding
    (dA/dX, dA/dY) per selected attribute ('all' = every attribute); without
    diff_attrs out_da is empty. Background pixels are 0. Runs on the device
    of the RasterizeVulkanContext that made rast (float32), whose out and
    out_da then take texture there too (docs/python.md, "Vulkan").
    """
    diff = _diff_list(diff_attrs, attr.shape[-1] if isinstance(attr, torch.Tensor) and attr.dim() >= 1 else 0)
    if diff and rast_db is None:
        raise ValueError("'diff_attrs' needs 'rast_db' (the second output of rasterize)")
    glctx = origin(rast)  # rasterize's context: its device runs this call, and texture on out
    rast_db = rast_db if diff else None
    out, out_da = _InterpolateFunc.apply(attr, rast, tri, rast_db, diff, _device(glctx),
                                         _kept(rast, tri=tri, rast_db=rast_db))
    if glctx is not None:
        record_origin(out, glctx)
        record_origin(out_da, glctx)
    return out, out_da


# ----------------------------------------------------------------------------
# Antialias.

def antialias_construct_topology_hash(tri):
    """Edge adjacency of `tri` for antialias (nvdiffrast's topology hash):
    build it once when the triangles stay the same."""
    return _topology(tri, -1, 'antialias_construct_topology_hash')


def _topology(tri, vertices, op):
    """The adjacency of tri, its indices checked first (against `vertices`; -1: unknown, negatives only)."""
    _tri(tri)
    return _core.build_topology(_d(tri), vertices, op)


# The topologies antialias built for itself, by tri (_topologies.py): a few meshes' worth (each holds 12 bytes per
# triangle on the host, and its device copies only while a frame keeps it).
_KEPT_TOPOLOGY_CAPACITY = 4
_KEPT_TOPOLOGIES = KeptTopologies(_KEPT_TOPOLOGY_CAPACITY, _fingerprint)


def _own_topology(tri, vertices, op):
    """The adjacency of tri for a call without topology_hash: the one kept for this very tri while it is unchanged,
    its indices within `vertices`; else built (indices checked against `vertices` first: never a table sized by a
    bad index) and kept."""
    topology = _KEPT_TOPOLOGIES.find(tri)
    if topology is not None and topology.vertices_needed <= vertices:
        return topology
    return _KEPT_TOPOLOGIES.built(tri, lambda: _topology(tri, vertices, op))


def _check_antialias(color, rast, pos, tri):
    _float('color', color, (4,))
    _rast('rast', rast, ('color', color))
    _float('pos', pos, (2, 3), like=('color', color))
    _tri(tri)
    if color.shape[:3] != rast.shape[:3]:
        raise ValueError(f"'color' {list(color.shape)} and 'rast' {list(rast.shape)} differ in minibatch or size")
    if color.shape[3] < 1:
        raise ValueError("'color' needs at least one channel")
    images = rast.shape[0]
    if pos.dim() == 3 and pos.shape[0] != images:
        raise ValueError(f"'pos' has minibatch size {pos.shape[0]} but 'rast' has {images}")
    if pos.shape[-1] != 4:
        raise ValueError(f"'pos' must have shape [..., num_vertices, 4], got {list(pos.shape)}")


def _antialias_mesh(color, rast, pos, tri):
    """_core's mesh arguments (pos, tri, ranges): [N, 4] pos is shared by every image, as one range of all of tri."""
    _check_antialias(color, rast, pos, tri)
    images, instanced = rast.shape[0], pos.dim() == 3
    return _d(pos), _d(tri), [] if instanced else [(0, tri.shape[0])] * images


# Scratch buffers of antialias (which takes no context); calls are serialized.
_ANTIALIAS_SCRATCH = _core.Context()


class _AntialiasFunc(torch.autograd.Function):
    @staticmethod
    def forward(ctx, color, rast, pos, tri, topology, boost, visibility, device, kept):
        mesh = _antialias_mesh(color, rast, pos, tri)
        out = torch.empty_like(color)
        # rast's context's device (with its scratch), else the CPU kernels with the module's scratch. The state
        # keeps the G-buffers' handles for the backward.
        scratch = device if device is not None else _ANTIALIAS_SCRATCH
        state = _core.antialias_forward(scratch, *mesh, topology, _d(color), _d(rast), out, visibility, _threads(),
                                        kept)
        ctx.save_for_backward(color, rast, pos, tri)
        ctx.topology, ctx.state, ctx.boost, ctx.scratch = topology, state, boost, scratch
        return out

    @staticmethod
    @once_differentiable
    def backward(ctx, dy):
        color, rast, pos, tri = _saved(ctx)
        mesh = _antialias_mesh(color, rast, pos, tri)
        need_color, _, need_pos = ctx.needs_input_grad[:3]
        g_color = torch.zeros_like(color) if need_color else None
        g_pos = torch.zeros_like(pos) if need_pos else None
        _core.antialias_backward(ctx.scratch, *mesh, ctx.topology, ctx.state, _d(color), _d(rast),
                                 _d(dy.contiguous()), g_color, g_pos, ctx.boost, _threads())
        return g_color, None, g_pos, None, None, None, None, None, None


def _apply_antialias(color, rast, pos, tri, topology_hash, pos_gradient_boost, visibility):
    boost = _real(pos_gradient_boost)
    if boost is None or not abs(boost) < float('inf'):
        raise ValueError(f"'pos_gradient_boost' must be a finite number, got {pos_gradient_boost!r}")
    _check_antialias(color, rast, pos, tri)
    if topology_hash is None:
        topology_hash = _own_topology(tri, pos.shape[-2], 'visibility_antialias' if visibility else 'antialias')
    elif not isinstance(topology_hash, _core.Topology):
        raise TypeError("'topology_hash' must come from antialias_construct_topology_hash(tri)")
    return _AntialiasFunc.apply(color, rast, pos, tri, topology_hash, boost, visibility,
                                _device(origin(rast)), _kept(rast, pos=pos, tri=tri))


def antialias(color, rast, pos, tri, topology_hash=None, pos_gradient_boost=1.0):
    """Antialias silhouette edges (nvdiffrast.torch.antialias).

    color: [minibatch, height, width, channels]; rast: rasterize's first
    output for the same pos and tri; pos: as given to rasterize. Returns the
    antialiased color; gradients flow to color and pos (the latter multiplied
    by pos_gradient_boost). topology_hash: from
    antialias_construct_topology_hash(tri), built here when None. Runs on the
    device of the RasterizeVulkanContext that made rast (float32).
    """
    return _apply_antialias(color, rast, pos, tri, topology_hash, pos_gradient_boost, False)


def visibility_antialias(color, rast, pos, tri, topology_hash=None, pos_gradient_boost=1.0):
    """Antialias every visibility boundary, including the curves where two
    surfaces cut through each other (not in nvdiffrast; docs/visibility_antialias.md).

    Arguments and result as antialias. Where nothing interpenetrates it
    equals antialias bit for bit; at an intersection curve it blends the two
    surfaces and sends the gradient to both triangles' vertices, which
    antialias cannot do. Runs on the device of the RasterizeVulkanContext
    that made rast (float32), as antialias.
    """
    return _apply_antialias(color, rast, pos, tri, topology_hash, pos_gradient_boost, True)


# ----------------------------------------------------------------------------
# Texture.

_FILTERS = {'nearest': 0, 'linear': 1, 'linear-mipmap-linear': 2, 'linear-mipmap-nearest': 3}
_CUBE = -1  # boundary_mode 'cube': a cube map
_BOUNDARIES = {'wrap': 0, 'clamp': 1, 'zero': 3, 'cube': _CUBE}
_MAX_TEXTURE_SIDE = 32768
_MAX_MIP_LEVEL = 64  # more than any chain has


class TextureMip:
    """A mip stack built by texture_construct_mip (nvdiffrast's
    TextureMipWrapper): levels 1.. of every texture image, box-filtered;
    gradients of lookups in it still flow to the base texture."""

    def __init__(self, tex, pyramid, sizes, cube):
        self.tex_shape, self.pyramid, self.sizes, self.cube = tuple(tex.shape), pyramid, sizes, cube


def _texture_mode(levels, user, filter_mode, boundary, device_levels=False):
    """boundary _CUBE: a cube map (tex [B, 6, S, S, C], uv directions, uv_dx = uv_da ([..., 6]), uv_dy None);
    device_levels: levels 1.. built on the device from tex (no pyramid)."""
    mode = _core.TextureMode()
    mode.device_levels = device_levels
    mode.cube = boundary == _CUBE
    mode.levels, mode.user = levels, user
    mode.filter, mode.wrap = filter_mode, boundary if not mode.cube else 0
    return mode


def _pyramid_texels(sizes, cube):
    return sum(h * w for h, w in sizes[1:]) * (6 if cube else 1)


def _check_prebuilt_mip(mip, tex):
    """The kernels read mip's stack as tex's levels 1..: same dtype, device, texture shape and level shapes."""
    if mip.tex_shape != tuple(tex.shape):
        raise ValueError(f"'mip' was built for a texture of shape {list(mip.tex_shape)}, 'tex' is {list(tex.shape)}")
    pyramid = mip.pyramid
    if not isinstance(pyramid, torch.Tensor):
        raise TypeError("'mip' holds no mip stack tensor; build it with texture_construct_mip(tex)")
    if pyramid.dtype != tex.dtype:
        raise TypeError(f"'mip' was built from a {pyramid.dtype} texture but 'tex' is {tex.dtype}; build it from "
                        f"this texture: texture_construct_mip(tex)")
    if pyramid.device != tex.device:
        raise ValueError(f"'mip' is on {pyramid.device} but 'tex' is on {tex.device}")
    levels = len(mip.sizes) - 1  # 0: built with max_mip_level=0 (level 0 only, an empty stack)
    if levels < 0 or list(mip.sizes) != _core.mip_sizes(tex.shape[-3], tex.shape[-2], levels):
        raise ValueError(f"'mip' levels {list(mip.sizes)} are not the mip chain of a {tex.shape[-3]} x {tex.shape[-2]} "
                         f"texture")
    want = (tex.shape[0], _pyramid_texels(mip.sizes, mip.cube), tex.shape[-1])
    if tuple(pyramid.shape) != want or not pyramid.is_contiguous():
        raise ValueError(f"'mip' holds a stack of shape {list(pyramid.shape)}, not the contiguous {list(want)} of "
                         f"levels {list(mip.sizes[1:])} of 'tex'")


def _build_pyramid(tex, sizes, cube=False):
    texels = _pyramid_texels(sizes, cube)
    pyramid = tex.new_empty((tex.shape[0], texels, tex.shape[-1]))
    if len(sizes) == 1:  # level 0 only: no stack to build
        return pyramid
    _core.mip_build(_texture_mode(len(sizes), False, 1, _CUBE if cube else 0), _d(tex), pyramid, _threads())
    return pyramid


class _OnDevice:
    """Where a texture call runs: a Vulkan context's _core.Context (`device`), the handles an earlier call kept
    for these very texels (`before`, or None) and, after the forward, the handles this call kept (`after`)."""

    def __init__(self, device, before):
        self.device, self.before, self.after = device, before, None


class _TextureFunc(torch.autograd.Function):
    @staticmethod
    def forward(ctx, on, filter_mode, boundary, levels, prebuilt, tex, uv, uv_dx, uv_dy, bias, *mip_levels):
        device = on.device if on is not None else None
        user = len(mip_levels) > 0
        if user:  # the user's levels in one buffer per texture image
            pyramid = torch.cat([m.reshape(m.shape[0], -1, m.shape[3]) for m in mip_levels], 1).contiguous()
        elif levels > 1 and prebuilt is None and device is None:
            pyramid = _build_pyramid(tex, _core.mip_sizes(tex.shape[-3], tex.shape[-2], levels - 1), boundary == _CUBE)
        else:  # one level, a prebuilt stack, or levels 1.. built on the device from tex
            pyramid = prebuilt
        device_levels = levels > 1 and pyramid is None
        mode = _texture_mode(levels, user, filter_mode, boundary, device_levels)
        out = tex.new_empty(uv.shape[:3] + (tex.shape[-1],))
        # Bilinear with a uv gradient: keep d out/d(u, v), so the backward reads no texel for it (the CPU
        # kernels; a device's backward reads the texels).
        jacobian = None
        if filter_mode == _FILTERS['linear'] and boundary != _CUBE and ctx.needs_input_grad[6] and device is None:
            jacobian = tex.new_empty(uv.shape[:3] + (2, tex.shape[-1]))
        # A Vulkan context keeps the texels on its device for the backward (torch keeps the saved tex and
        # pyramid unchanged until then: it refuses a backward after an in-place write into them), and for later
        # calls on the same texture (_resident.KeptTextures).
        ctx.kept = _core.texture_forward(device, mode, _d(tex), _d(uv), _d(uv_dx), _d(uv_dy), _d(bias), _d(pyramid),
                                         out, jacobian, _threads(), on.before if on is not None else None)
        if on is not None:
            on.after = ctx.kept
        ctx.save_for_backward(tex, uv, uv_dx, uv_dy, bias, pyramid, jacobian)
        ctx.filter_mode, ctx.boundary, ctx.levels, ctx.user, ctx.device = filter_mode, boundary, levels, user, device
        ctx.device_levels = device_levels
        ctx.mip_shapes = [m.shape for m in mip_levels]
        return out

    @staticmethod
    @once_differentiable
    def backward(ctx, dy):
        tex, uv, uv_dx, uv_dy, bias, pyramid, jacobian = _saved(ctx)
        needs = ctx.needs_input_grad[1:]  # as forward's arguments after `on`
        zeros = lambda t, need: torch.zeros_like(t) if need and t is not None else None
        g_tex, g_uv = zeros(tex, needs[4]), zeros(uv, needs[5] and ctx.filter_mode != 0)
        g_dx, g_dy, g_bias = zeros(uv_dx, needs[6]), zeros(uv_dy, needs[7]), zeros(bias, needs[8])
        g_pyr = zeros(pyramid, ctx.user and any(needs[9:]))
        mode = _texture_mode(ctx.levels, ctx.user, ctx.filter_mode, ctx.boundary, ctx.device_levels)
        _core.texture_backward(ctx.device, mode, _d(tex), _d(uv), _d(uv_dx), _d(uv_dy), _d(bias), _d(pyramid),
                               _d(jacobian), _d(dy.contiguous()), g_tex, g_uv, g_dx, g_dy, g_bias, g_pyr, _threads(),
                               ctx.kept)
        g_levels, start = [], 0
        for shape in ctx.mip_shapes:
            n = shape[1] * shape[2]
            g_levels.append(g_pyr[:, start:start + n].reshape(shape) if g_pyr is not None else None)
            start += n
        return (None, None, None, None, None, g_tex, g_uv, g_dx, g_dy, g_bias, *g_levels)


def _texture_tensor(tex, cube=False):
    _float('tex', tex)
    if cube:
        if tex.dim() != 5 or tex.shape[1] != 6 or tex.shape[2] != tex.shape[3] or min(tex.shape) < 1:
            raise ValueError(f"boundary_mode 'cube' needs 'tex' of shape [minibatch_size, 6, size, size, channels] "
                             f"(6 square faces), got {list(tex.shape)}")
    elif tex.dim() == 5:
        raise ValueError(f"'tex' {list(tex.shape)} is a cube map: set boundary_mode='cube'")
    elif tex.dim() != 4 or min(tex.shape) < 1:
        raise ValueError(f"'tex' must have shape [minibatch_size, tex_height, tex_width, tex_channels] with all sizes "
                         f">= 1, got {list(tex.shape)}")
    if max(tex.shape[-3], tex.shape[-2]) > _MAX_TEXTURE_SIDE:
        raise ValueError(f"'tex' sides must be at most {_MAX_TEXTURE_SIDE}, got {list(tex.shape)}")
    return tex


def _max_mip_level(max_mip_level):
    if max_mip_level is None:
        return -1
    level = _integer(max_mip_level)
    if level is None or level < 0:
        raise ValueError(f"'max_mip_level' must be None or an integer >= 0, got {max_mip_level!r}")
    # A limit past the chain's last level (at most 15 for 32768 texels) is the whole chain, however large.
    return min(level, _MAX_MIP_LEVEL)


def texture_construct_mip(tex, max_mip_level=None, cube_mode=False):
    """Build the mip stack of a texture that stays constant, for texture(mip=...)."""
    if cube_mode is not True and cube_mode is not False:
        raise TypeError(f"'cube_mode' must be True or False, got {cube_mode!r}")
    _texture_tensor(tex, cube_mode)
    sizes = _core.mip_sizes(tex.shape[-3], tex.shape[-2], _max_mip_level(max_mip_level))
    with torch.no_grad():
        return TextureMip(tex, _build_pyramid(tex.detach(), sizes, cube_mode), sizes, cube_mode)


def texture(tex, uv, uv_da=None, mip_level_bias=None, mip=None, filter_mode='auto', boundary_mode='wrap',
            max_mip_level=None):
    """Texture lookups (nvdiffrast.torch.texture).

    tex: [minibatch (or 1), tex_height, tex_width, channels]; uv: [minibatch,
    height, width, 2] with texel (i, j) (column, row) centred at ((i + 0.5) / W,
    (j + 0.5) / H); uv_da: [minibatch, height, width, 4] = (du/dX, du/dY,
    dv/dX, dv/dY); mip_level_bias: [minibatch, height, width]; mip: a
    texture_construct_mip result or a list of tensors for levels 1.. (each
    [minibatch (or 1), h_l, w_l, channels]; they get their own gradients).
    filter_mode: 'auto', 'nearest', 'linear', 'linear-mipmap-nearest',
    'linear-mipmap-linear'; boundary_mode: 'wrap', 'clamp', 'zero' or 'cube'
    (tex [minibatch, 6, size, size, channels] looked up by uv = directions
    [minibatch, height, width, 3], uv_da [..., 6]; docs/cube_maps.md).
    Returns [minibatch, height, width, channels]. Runs on the device of a
    RasterizeVulkanContext when uv is interpolate's output for its rast (float32).
    """
    if filter_mode == 'auto':
        filter_mode = 'linear-mipmap-linear' if (uv_da is not None or mip_level_bias is not None) else 'linear'
    if not isinstance(filter_mode, str) or filter_mode not in _FILTERS:
        raise ValueError(f"'filter_mode' must be one of 'auto', 'nearest', 'linear', 'linear-mipmap-nearest', "
                         f"'linear-mipmap-linear', got {filter_mode!r}")
    if not isinstance(boundary_mode, str) or boundary_mode not in _BOUNDARIES:
        raise ValueError(f"'boundary_mode' must be one of 'wrap', 'clamp', 'zero', 'cube', got {boundary_mode!r}")
    max_level = _max_mip_level(max_mip_level)
    cube = boundary_mode == 'cube'
    _texture_tensor(tex, cube)
    _float('uv', uv, (4,), like=('tex', tex))
    dims = 3 if cube else 2
    if uv.shape[3] != dims:
        raise ValueError(f"'uv' must have shape [minibatch_size, height, width, {dims}]"
                         f"{' (directions) for a cube map' if cube else ''}, got {list(uv.shape)}")
    if tex.shape[0] not in (1, uv.shape[0]):
        raise ValueError(f"'tex' has minibatch size {tex.shape[0]} but 'uv' has {uv.shape[0]} (broadcast needs 1)")
    mipmapped = filter_mode in ('linear-mipmap-linear', 'linear-mipmap-nearest')
    if mipmapped and max_level == 0:
        filter_mode, mipmapped = 'linear', False
    if mipmapped and uv_da is None and mip_level_bias is None:
        raise ValueError(f"filter_mode {filter_mode!r} needs 'uv_da' or 'mip_level_bias'")
    uv_dx = uv_dy = bias = None
    if mipmapped:
        if uv_da is not None:
            _float('uv_da', uv_da, (4,), like=('tex', tex))
            if uv_da.shape != uv.shape[:3] + (2 * dims,):
                raise ValueError(f"'uv_da' must have shape {list(uv.shape[:3]) + [2 * dims]}, got {list(uv_da.shape)}")
        if cube:
            uv_dx = uv_da  # the cube kernel reads nvdiffrast's layout; without it the level is the bias
        elif uv_da is not None:
            # (du/dX, du/dY, dv/dX, dv/dY) -> per-axis (du, dv) pairs; torch carries the gradient back.
            uv_dx, uv_dy = uv_da[..., 0::2].contiguous(), uv_da[..., 1::2].contiguous()
        else:
            # Bias only: a footprint of exactly one texel, so the level is the bias.
            uv_dx = uv.new_zeros(uv.shape)
            uv_dx[..., 0] = 1.0 / tex.shape[2]
            uv_dy = uv.new_zeros(uv.shape)
        if mip_level_bias is not None:
            _float('mip_level_bias', mip_level_bias, (3,), like=('tex', tex))
            if mip_level_bias.shape != uv.shape[:3]:
                raise ValueError(f"'mip_level_bias' must have shape {list(uv.shape[:3])}, got "
                                 f"{list(mip_level_bias.shape)}")
            bias = mip_level_bias
    sizes = _core.mip_sizes(tex.shape[-3], tex.shape[-2], max_level) if mipmapped else [tuple(tex.shape[-3:-1])]
    prebuilt, levels = None, []
    if mipmapped and mip is not None:
        if isinstance(mip, TextureMip):
            if mip.cube != cube:
                raise ValueError(f"'mip' was built with cube_mode={mip.cube} but boundary_mode is {boundary_mode!r}")
            _check_prebuilt_mip(mip, tex)
            # A stack of level 0 only (max_mip_level=0) has nothing for the kernels to read.
            prebuilt, sizes = mip.pyramid if len(mip.sizes) > 1 else None, mip.sizes
        elif isinstance(mip, (list, tuple)) and cube:
            raise NotImplementedError("texture: a custom mip stack (a list) for a cube map is not implemented yet in "
                                      "gradraster; use texture_construct_mip(tex, cube_mode=True)")
        elif isinstance(mip, (list, tuple)):
            levels = list(mip)
            if len(levels) < 1 or len(levels) > len(sizes) - 1:
                raise ValueError(f"'mip' must hold 1..{len(sizes) - 1} levels for a {tex.shape[1]} x {tex.shape[2]} "
                                 f"texture, got {len(levels)}")
            sizes = sizes[:len(levels) + 1]
            for k, m in enumerate(levels):
                _float(f'mip[{k}]', m, (4,), like=('tex', tex))
                want = [tex.shape[0], sizes[k + 1][0], sizes[k + 1][1], tex.shape[3]]
                if list(m.shape) != want:
                    raise ValueError(f"'mip[{k}]' must have shape {want} (level {k + 1} of the mip chain), got "
                                     f"{list(m.shape)}")
        else:
            raise TypeError("'mip' must be a texture_construct_mip result or a list of tensors")
    # uv from interpolate on a RasterizeVulkanContext's rast: the lookups run on its device (float32), which
    # keeps the texels while these tensors are unchanged (the mip levels built here are tex's).
    glctx = origin(uv)
    device = _device(glctx) if tex.dtype == torch.float32 else None
    on, texels, how = None, None, None
    if device is not None:
        texels = [tex] + ([prebuilt] if prebuilt is not None else levels)
        how = (cube, len(sizes), prebuilt is not None, len(levels))
        texels = glctx.kept_textures.texels(texels)
        on = _OnDevice(device, glctx.kept_textures.find(how, texels))
    out = _TextureFunc.apply(on, _FILTERS[filter_mode], _BOUNDARIES[boundary_mode], len(sizes), prebuilt, tex,
                             uv, uv_dx, uv_dy, bias, *levels)
    if on is not None:
        glctx.kept_textures.keep(how, texels, on.after)
    return out
