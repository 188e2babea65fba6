"""gradraster._core checks its inputs itself: called directly, past every check
in gradraster.torch, wrong dtypes, shapes, layouts, sizes, aliasing and
values are Python exceptions (never a crash, never a read out of bounds), and
the tensors a call views live until its kernels are done."""
import gc
import weakref

import numpy as np
import pytest
import torch

import gradraster.torch as dr
from gradraster import _core
from conftest import two_triangles

F64 = torch.float64


@pytest.fixture
def scene(glctx):
    pos, tri = two_triangles()
    rast, db = dr.rasterize(glctx, pos, tri, (8, 8))
    return pos, tri, rast, db


def raster_call(pos, tri, rast, db=None, ranges=()):
    _core.rasterize_forward(_core.Context(), pos, tri, list(ranges), rast, db, None, 1)


def test_addresses_and_capsules_are_refused(scene):
    pos, tri, rast, _ = scene
    with pytest.raises(TypeError, match="'pos' must be a tensor exporting DLPack"):
        raster_call(pos.data_ptr(), tri, torch.empty_like(rast))
    with pytest.raises(TypeError, match="'rast' must be a tensor exporting DLPack"):
        raster_call(pos, tri, rast.data_ptr())
    with pytest.raises(TypeError, match="not a DLPack capsule"):
        raster_call(pos.__dlpack__(), tri, torch.empty_like(rast))


def test_wrong_dtypes_are_type_errors(scene):
    pos, tri, rast, _ = scene
    out = torch.empty_like(rast)
    with pytest.raises(TypeError, match="rasterize: 'tri' has element type int64"):
        raster_call(pos, tri.long(), out)
    with pytest.raises(TypeError, match="'pos' has element type float16"):
        raster_call(pos.half(), tri, out)
    with pytest.raises(TypeError, match="rasterize: 'rast' has dtype float32 but the positions"):
        raster_call(pos, tri, out.float())
    with pytest.raises(TypeError, match="rasterize: 'tri' must have dtype int32, got float32"):
        raster_call(pos, tri.float(), out)
    with pytest.raises(TypeError, match="'attr' has dtype float32 but 'rast' has float64"):
        _core.interpolate_forward(None, torch.zeros(4, 2), rast, tri, None, [], torch.empty(1, 8, 8, 2), None, 1)
    with pytest.raises(TypeError, match="write_png: 'image' must have dtype float32"):
        _core.write_png('/nonexistent/x.png', np.zeros((2, 2, 3)))
    with pytest.raises(RuntimeError, match="require gradient"):  # torch refuses to export it
        raster_call(pos.clone().requires_grad_(True), tri, out)


def test_non_contiguous_inputs_and_outputs_are_refused_not_copied(scene):
    pos, tri, rast, _ = scene
    strided = pos.transpose(1, 2).contiguous().transpose(1, 2)
    with pytest.raises(ValueError, match="rasterize: 'pos' is not contiguous"):
        raster_call(strided, tri, torch.empty_like(rast))
    out = torch.empty(1, 8, 16, 4, dtype=F64)[:, :, ::2]
    with pytest.raises(ValueError, match="'rast' is not contiguous"):
        raster_call(pos, tri, out)
    color = torch.zeros(1, 8, 8, 6, dtype=F64)[..., ::2]
    topology = _core.build_topology(tri, 4, 'antialias')
    with pytest.raises(ValueError, match="antialias: 'color' is not contiguous"):
        _core.antialias_forward(_core.Context(), pos, tri, [], topology, color, rast, torch.empty(1, 8, 8, 3,
                                                                                                 dtype=F64), False, 1)


def test_wrong_shapes_and_too_small_outputs_are_value_errors(scene):
    pos, tri, rast, db = scene
    with pytest.raises(ValueError, match=r"'pos' must have shape \[..., num_vertices, 4\], got \[1, 4, 3\]"):
        raster_call(pos[..., :3].contiguous(), tri, torch.empty_like(rast))
    with pytest.raises(ValueError, match=r"'tri' must have shape \[num_triangles, 3\]"):
        raster_call(pos, tri[:, :2].contiguous(), torch.empty_like(rast))
    with pytest.raises(ValueError, match="range mode - 'pos' is \\[num_vertices, 4\\], so 'ranges'"):
        raster_call(pos[0], tri, torch.empty_like(rast))
    with pytest.raises(ValueError, match=r"'rast' must have shape \[minibatch_size, height, width, 4\], got "
                                         r"\[2, 8, 8, 4\]"):
        raster_call(pos, tri, torch.empty(2, 8, 8, 4, dtype=F64))
    with pytest.raises(ValueError, match=r"'rast_db' must have shape \[1, 8, 8, 4\], got \[1, 8, 7, 4\]"):
        raster_call(pos, tri, torch.empty_like(rast), torch.empty(1, 8, 7, 4, dtype=F64))
    with pytest.raises(ValueError, match=r"image size 16385 x 8 is outside 1..16384 per side"):
        raster_call(pos, tri, torch.empty(1, 8, 16385, 4, dtype=F64))
    # interpolate: outputs too small, derivatives without their buffer, bad diff indices.
    attr = pos[0]
    with pytest.raises(ValueError, match=r"interpolate: 'out' must have shape \[1, 8, 8, 4\], got \[1, 8, 8, 3\]"):
        _core.interpolate_forward(None, attr, rast, tri, None, [], torch.empty(1, 8, 8, 3, dtype=F64), None, 1)
    with pytest.raises(ValueError, match="'out_da' is required"):
        _core.interpolate_forward(None, attr, rast, tri, db, [0], torch.empty(1, 8, 8, 4, dtype=F64), None, 1)
    with pytest.raises(ValueError, match=r"'out_da' must have shape \[1, 8, 8, 2\]"):
        _core.interpolate_forward(None, attr, rast, tri, db, [0], torch.empty(1, 8, 8, 4, dtype=F64),
                                  torch.empty(1, 8, 8, 1, dtype=F64), 1)
    with pytest.raises(ValueError, match="'diff_attrs' index 4 is outside 0..3"):
        _core.interpolate_forward(None, attr, rast, tri, db, [4], torch.empty(1, 8, 8, 4, dtype=F64),
                                  torch.empty(1, 8, 8, 2, dtype=F64), 1)
    with pytest.raises(ValueError, match="'rast_db' is required"):
        _core.interpolate_forward(None, attr, rast, tri, None, [0], torch.empty(1, 8, 8, 4, dtype=F64),
                                  torch.empty(1, 8, 8, 2, dtype=F64), 1)
    with pytest.raises(ValueError, match="'attr' has minibatch size 2 but 'rast' has 1"):
        _core.interpolate_forward(None, torch.zeros(2, 4, 3, dtype=F64), rast, tri, None, [],
                                  torch.empty(1, 8, 8, 3, dtype=F64), None, 1)
    with pytest.raises(ValueError, match=r"interpolate backward: 'grad_attr' must have shape \[4, 4\]"):
        _core.interpolate_backward(None, attr, rast, tri, None, [], torch.ones(1, 8, 8, 4, dtype=F64), None,
                                   torch.zeros(3, 4, dtype=F64), None, None, 1)
    # antialias: the colour must match rast, the output the colour.
    topology = _core.build_topology(tri, 4, 'antialias')
    color = torch.rand(1, 8, 8, 3, dtype=F64)
    with pytest.raises(ValueError, match=r"antialias: 'color' must have shape \[minibatch_size, height, width, "
                                         r"channels\] as 'rast', got \[1, 8, 7, 3\]"):
        _core.antialias_forward(_core.Context(), pos, tri, [], topology, torch.rand(1, 8, 7, 3, dtype=F64), rast,
                                torch.empty(1, 8, 7, 3, dtype=F64), False, 1)
    with pytest.raises(ValueError, match=r"antialias: 'out' must have shape \[1, 8, 8, 3\], got \[1, 8, 8, 2\]"):
        _core.antialias_forward(_core.Context(), pos, tri, [], topology, color, rast,
                                torch.empty(1, 8, 8, 2, dtype=F64), False, 1)


def test_outputs_that_share_memory_with_an_input_are_refused(scene):
    pos, tri, rast, _ = scene
    topology = _core.build_topology(tri, 4, 'antialias')
    color = torch.rand(1, 8, 8, 3, dtype=F64)
    with pytest.raises(ValueError, match="antialias: the output 'out' shares memory with the input 'color'"):
        _core.antialias_forward(_core.Context(), pos, tri, [], topology, color, rast, color, False, 1)
    both = torch.empty(2, 8, 8, 4, dtype=F64)
    with pytest.raises(ValueError, match="the outputs 'rast' and 'rast_db' share memory"):
        raster_call(pos, tri, both[:1], both.view(-1)[100:100 + 256].view(1, 8, 8, 4))


def test_an_antialias_state_from_another_call_is_refused(glctx, scene):
    pos, tri, rast, _ = scene
    topology = _core.build_topology(tri, 4, 'antialias')
    state = _core.antialias_forward(_core.Context(), pos, tri, [], topology, torch.rand(1, 8, 8, 3, dtype=F64), rast,
                                    torch.empty(1, 8, 8, 3, dtype=F64), False, 1)
    big, _ = dr.rasterize(glctx, pos, tri, (16, 16))  # the state's pixel pairs index an 8 x 8 image
    color = torch.rand(1, 16, 16, 3, dtype=F64)
    with pytest.raises(ValueError, match="the state is of a forward call with 1 images of 8 x 8 x 3"):
        _core.antialias_backward(_core.Context(), pos, tri, [], topology, state, color, big, torch.ones_like(color),
                                 torch.zeros_like(color), torch.zeros_like(pos), 1.0, 1)


def test_backward_passes_check_the_values_they_index_with(scene):
    pos, tri, rast, db = scene
    bad = rast.clone()
    bad[0, 3, 3, 3] = 7  # a triangle id past 'tri'
    with pytest.raises(IndexError, match=r"rasterize backward: rast\[..., 3\]"):
        _core.rasterize_backward(_core.Context(), pos, tri, [], bad, torch.ones_like(rast), None,
                                 torch.zeros_like(pos), 1)
    with pytest.raises(IndexError, match="interpolate backward"):
        _core.interpolate_backward(None, pos[0], bad, tri, None, [], torch.ones(1, 8, 8, 4, dtype=F64), None,
                                   torch.zeros(4, 4, dtype=F64), None, None, 1)
    topology = _core.build_topology(tri, 4, 'antialias')
    color = torch.rand(1, 8, 8, 3, dtype=F64)
    with pytest.raises(IndexError, match=r"antialias: rast\[..., 3\] .* at pixel 27"):
        _core.antialias_forward(_core.Context(), pos, tri, [], topology, color, bad, torch.empty_like(color), False, 1)
    state = _core.antialias_forward(_core.Context(), pos, tri, [], topology, color, rast, torch.empty_like(color),
                                    False, 1)
    bad[0, 3, 3, 3] = 0.5  # not an integer
    with pytest.raises(IndexError, match="antialias backward: .* is 0.5"):
        _core.antialias_backward(_core.Context(), pos, tri, [], topology, state, color, bad, torch.ones_like(color),
                                 torch.zeros_like(color), torch.zeros_like(pos), 1.0, 1)
    bad_tri = tri.clone()
    bad_tri[1, 1] = 9
    with pytest.raises(IndexError, match="rasterize backward"):
        _core.rasterize_backward(_core.Context(), pos, bad_tri, [], rast, torch.ones_like(rast), None,
                                 torch.zeros_like(pos), 1)
    mode = _core.TextureMode()
    tex = torch.rand(1, 4, 4, 3, dtype=F64)
    uv = torch.rand(1, 2, 2, 2, dtype=F64)
    uv[0, 1, 1, 0] = float('nan')
    with pytest.raises(ValueError, match="texture backward.*uv"):
        _core.texture_backward(None, mode, tex, uv, None, None, None, None, None, torch.ones(1, 2, 2, 3, dtype=F64),
                               torch.zeros_like(tex), torch.zeros_like(uv), None, None, None, None, 1)


def test_texture_arguments_are_checked_against_each_other():
    tex = torch.rand(2, 8, 8, 3, dtype=F64)
    uv = torch.rand(2, 3, 3, 2, dtype=F64)
    out = torch.empty(2, 3, 3, 3, dtype=F64)
    mode = _core.TextureMode()

    def forward(mode=mode, tex=tex, uv=uv, uv_dx=None, uv_dy=None, bias=None, pyramid=None, out=out, jac=None):
        _core.texture_forward(None, mode, tex, uv, uv_dx, uv_dy, bias, pyramid, out, jac, 1)

    forward()  # the baseline call is fine
    with pytest.raises(ValueError, match=r"texture: 'out' must have shape \[2, 3, 3, 3\]"):
        forward(out=torch.empty(2, 3, 3, 2, dtype=F64))
    with pytest.raises(ValueError, match="'tex' has minibatch size 2 but 'uv' has 3"):
        forward(uv=torch.rand(3, 3, 3, 2, dtype=F64), out=torch.empty(3, 3, 3, 3, dtype=F64))
    with pytest.raises(ValueError, match=r"'uv' must have shape \[-1, -1, -1, 2\]"):
        forward(uv=torch.rand(2, 3, 3, 3, dtype=F64))
    with pytest.raises(ValueError, match="'tex' sides must be at most 32768"):
        forward(tex=torch.empty(1, 32769, 1, 1, dtype=F64))
    mip = _core.TextureMode()
    mip.levels, mip.filter = 4, 2
    ok_pyramid = torch.rand(2, 16 + 4 + 1, 3, dtype=F64)
    dx = torch.rand(2, 3, 3, 2, dtype=F64) * 0.1
    forward(mode=mip, uv_dx=dx, uv_dy=dx.clone(), pyramid=ok_pyramid)
    with pytest.raises(ValueError, match=r"'pyramid' must have shape \[2, 21, 3\], got \[2, 20, 3\]"):
        forward(mode=mip, uv_dx=dx, uv_dy=dx.clone(), pyramid=ok_pyramid[:, :20].contiguous())
    with pytest.raises(ValueError, match="'pyramid' is required"):
        forward(mode=mip, uv_dx=dx, uv_dy=dx.clone())
    mip.levels = 5  # an 8 x 8 chain has 4 levels
    with pytest.raises(ValueError, match="5 mip levels; a 8 x 8 texture has 1..4"):
        forward(mode=mip, uv_dx=dx, uv_dy=dx.clone(), pyramid=ok_pyramid)
    with pytest.raises(ValueError, match=r"'uv_jacobian' must have shape \[2, 3, 3, 2, 3\]"):
        forward(jac=torch.empty(2, 3, 3, 2, 2, dtype=F64))
    shared = torch.rand(2 * 3 * 3 * 3, dtype=F64)
    with pytest.raises(ValueError, match="shares memory with the input 'uv'"):
        forward(uv=shared[:36].view(2, 3, 3, 2), out=shared.view(2, 3, 3, 3))
    with pytest.raises(ValueError, match="'grad_pyramid' is given but 'pyramid' is not"):
        _core.texture_backward(None, mode, tex, uv, None, None, None, None, None, torch.ones_like(out),
                               None, None, None, None, None, torch.zeros(2, 21, 3, dtype=F64), 1)
    with pytest.raises(ValueError, match=r"'grad_tex' must have shape \[2, 8, 8, 3\]"):
        _core.texture_backward(None, mode, tex, uv, None, None, None, None, None, torch.ones_like(out),
                               torch.zeros(1, 8, 8, 3, dtype=F64), None, None, None, None, None, 1)
    mip.levels = 4
    with pytest.raises(ValueError, match="texture_construct_mip: 'pyramid' is required"):
        _core.mip_build(mip, tex, None, 1)


class Vanishing:
    """Exports its tensor once, then drops it: once _core has taken its view,
    nothing on the Python side refers to the tensor any more. Then memory of
    the same size is allocated and written (it would get the freed block)."""

    def __init__(self, t):
        self.t = t
        self.ref = weakref.ref(t)
        self.scribble = None

    def __dlpack__(self, stream=None):
        capsule, n = self.t.__dlpack__(), self.t.numel()
        self.t = None
        gc.collect()
        self.scribble = [torch.full((n,), 1e30, dtype=F64) for _ in range(8)]
        return capsule


def test_tensors_dropped_by_python_after_the_call_starts_stay_alive_until_it_returns(glctx, scene):
    """The old binding took integer addresses: a tensor freed after its
    address was taken was read freed (a texture backward did). Now _core holds
    what it views, so a tensor whose last Python reference goes once the call
    has started is still read correctly (and the ASan build would report a
    read of freed memory), and is released when the call returns."""
    pos, tri, rast, db = scene
    attr = torch.rand(4, 5, dtype=F64)
    want = torch.empty(1, 8, 8, 5, dtype=F64)
    _core.interpolate_forward(None, attr, rast, tri, None, [], want, None, 1)
    vanishing = Vanishing(attr.clone())
    got = torch.empty_like(want)
    _core.interpolate_forward(None, vanishing, rast, tri, None, [], got, None, 1)
    assert torch.equal(got, want)
    gc.collect()
    assert vanishing.ref() is None  # released after the call: nothing kept, nothing leaked

    # The texture backward's upstream gradient, the temporary that was once read freed.
    tex = torch.rand(1, 16, 16, 3, dtype=F64)
    uv = torch.rand(1, 8, 8, 2, dtype=F64)
    dy = torch.rand(1, 8, 8, 3, dtype=F64)
    mode = _core.TextureMode()
    want = torch.zeros_like(tex)
    _core.texture_backward(None, mode, tex, uv, None, None, None, None, None, dy, want, None, None, None, None, None, 1)
    got = torch.zeros_like(tex)
    _core.texture_backward(None, mode, tex, uv, None, None, None, None, None, Vanishing(dy.clone()), got, None, None,
                           None, None, None, 1)
    assert torch.equal(got, want)


def test_the_checks_are_the_same_for_float32_and_numpy_arrays(scene):
    """Any DLPack producer works; a writeable numpy array is viewed in place."""
    pos, tri, rast, _ = scene
    out = np.zeros((1, 8, 8, 4), np.float64)
    raster_call(pos.numpy(), tri.numpy(), out)
    assert np.array_equal(out, rast.numpy())
    with pytest.raises(ValueError, match="'rast' is not contiguous"):
        raster_call(pos.numpy(), tri.numpy(), np.zeros((1, 8, 8, 8))[..., ::2])
