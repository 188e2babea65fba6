"""Every op's backward reads its upstream gradient whatever the gradient's memory layout.

torch hands a backward the gradient as the ops after it made it: expanded from
a scalar by sum() (stride 0), permuted (a loss on an NCHW view), sliced, at an
offset into a larger storage. Each layout must give the same gradients, bit for
bit, as the same values given contiguous. (Issue 30: texture's backward passed
the address of a contiguous copy that was freed before the kernel read it.)
"""
import os
import subprocess
import sys
import textwrap

import pytest
import torch

import gradraster.torch as dr
from conftest import random_mesh


def relayouts(g):
    """The values of g [B, H, W, C] in other memory layouts, as (name, tensor) pairs."""
    b, h, w, c = g.shape
    wide = g.new_zeros(b, h, w, c + 2)
    wide[..., 1:c + 1] = g
    tall = g.new_zeros(b, 2 * h, w, c)
    tall[:, ::2] = g
    flat = torch.cat([g.new_zeros(3), g.flatten()])
    return [('permuted (NCHW storage)', g.permute(0, 3, 1, 2).contiguous().permute(0, 2, 3, 1)),
            ('rows and columns transposed', g.transpose(1, 2).contiguous().transpose(1, 2)),
            ('a slice of wider channels', wide[..., 1:c + 1]),
            ('every other row of a taller tensor', tall[:, ::2]),
            ('at an offset into its storage', flat[3:].view(g.shape))]


def upstream_cases(outputs, seed=0):
    """(name, contiguous gradients, the same values in another layout), one gradient per output."""
    gen = torch.Generator().manual_seed(seed)
    grads = [torch.rand(o.shape, generator=gen, dtype=o.dtype) - 0.5 for o in outputs]
    # sum() hands back a scalar expanded to the output's shape: every stride 0.
    expanded = [torch.tensor(0.25 + k, dtype=o.dtype).expand(o.shape) for k, o in enumerate(outputs)]
    cases = [('expanded from a scalar, as after sum()', [e.contiguous() for e in expanded], expanded)]
    if outputs[0].shape[0] > 1:
        firsts = [g[:1].expand(g.shape) for g in grads]
        cases.append(('expanded over the minibatch', [f.contiguous() for f in firsts], firsts))
    moved = [relayouts(g) for g in grads]
    for k, (name, _) in enumerate(moved[0]):
        cases.append((name, grads, [m[k][1] for m in moved]))
    return cases


def assert_gradients_ignore_upstream_layout(outputs, inputs):
    for name, contiguous, other in upstream_cases(outputs):
        assert any(not g.is_contiguous() for g in other) or 'offset' in name
        want = torch.autograd.grad(outputs, inputs, contiguous, retain_graph=True, allow_unused=True)
        got = torch.autograd.grad(outputs, inputs, other, retain_graph=True, allow_unused=True)
        for k, (a, b) in enumerate(zip(want, got)):
            assert (a is None) == (b is None), f"{name}: input {k}"
            assert a is None or torch.equal(a, b), f"{name}: input {k}'s gradient differs from a contiguous upstream's"


# ----------------------------------------------------------------------------
# Rasterize, interpolate, the peeler.

def scene(mode, dtype=torch.float64):
    """(pos, tri, ranges): two images, instanced or in range mode."""
    if mode == 'instanced':
        pos, tri = random_mesh(11, images=2, triangles=10, dtype=dtype)
        return pos.requires_grad_(True), tri, None
    pos, tri = random_mesh(11, images=1, triangles=10, dtype=dtype)
    ranges = torch.tensor([[0, 6], [4, 6]], dtype=torch.int32)
    return pos[0].detach().clone().requires_grad_(True), tri, ranges


@pytest.mark.parametrize('dtype', [torch.float32, torch.float64])
@pytest.mark.parametrize('grad_db', [True, False])
@pytest.mark.parametrize('mode', ['instanced', 'range'])
def test_rasterize_backward_matches_a_contiguous_upstream_for_every_layout(glctx, mode, grad_db, dtype):
    pos, tri, ranges = scene(mode, dtype)
    rast, db = dr.rasterize(glctx, pos, tri, (12, 10), ranges=ranges, grad_db=grad_db)
    assert_gradients_ignore_upstream_layout([rast, db], [pos])


@pytest.mark.parametrize('diff_attrs', [None, 'all', [1]])
def test_interpolate_backward_matches_a_contiguous_upstream_for_every_layout(glctx, diff_attrs):
    pos, tri, _ = scene('instanced')
    rast, db = dr.rasterize(glctx, pos, tri, (12, 10))
    attr = torch.rand(1, pos.shape[1], 3, dtype=torch.float64, requires_grad=True)
    out, out_da = dr.interpolate(attr, rast, tri, rast_db=db, diff_attrs=diff_attrs)
    outputs = [out, out_da] if diff_attrs is not None else [out]
    assert_gradients_ignore_upstream_layout(outputs, [attr, pos])


def test_depth_peeler_layers_backward_matches_a_contiguous_upstream_for_every_layout(glctx):
    pos, tri, _ = scene('instanced')
    with dr.DepthPeeler(glctx, pos, tri, (12, 10)) as peeler:
        layers = [peeler.rasterize_next_layer() for _ in range(3)]
    for rast, db in layers:
        assert_gradients_ignore_upstream_layout([rast, db], [pos])


# ----------------------------------------------------------------------------
# Antialias.

@pytest.mark.parametrize('op', [dr.antialias, dr.visibility_antialias])
@pytest.mark.parametrize('mode', ['instanced', 'range'])
def test_antialias_backward_matches_a_contiguous_upstream_for_every_layout(glctx, op, mode):
    pos, tri, ranges = scene(mode)
    rast, _ = dr.rasterize(glctx, pos, tri, (12, 10), ranges=ranges)
    color = torch.rand(2, 12, 10, 3, dtype=torch.float64, requires_grad=True)
    # antialias takes instanced positions or one set shared by every image.
    out = op(color, rast, pos, tri)
    assert_gradients_ignore_upstream_layout([out], [color, pos])


# ----------------------------------------------------------------------------
# Texture: every filter and boundary mode, and every source of the mip stack.

MIPMAPPED = ('linear-mipmap-nearest', 'linear-mipmap-linear')


def texture_cases():
    for filter_mode in ('nearest', 'linear') + MIPMAPPED:
        for boundary in ('wrap', 'clamp', 'zero', 'cube'):
            sources = ['built'] if filter_mode not in MIPMAPPED else \
                ['built', 'texture_construct_mip'] + (['a list'] if boundary != 'cube' else [])
            for source in sources:
                yield filter_mode, boundary, source


def texture_inputs(boundary, dtype=torch.float64, size=(3, 4)):
    """tex, uv, uv_da, bias for two images, every one requiring a gradient."""
    gen = torch.Generator().manual_seed(5)
    cube = boundary == 'cube'
    tex_shape = (2, 6, 8, 8, 3) if cube else (2, 16, 8, 3)
    tex = torch.rand(tex_shape, generator=gen, dtype=dtype)
    if cube:
        uv = torch.randn(2, *size, 3, generator=gen, dtype=dtype)
        uv_da = torch.randn(2, *size, 6, generator=gen, dtype=dtype) * 0.3
    else:
        uv = torch.rand(2, *size, 2, generator=gen, dtype=dtype) * 1.4 - 0.2
        uv_da = torch.rand(2, *size, 4, generator=gen, dtype=dtype) * 0.2 + 0.1
    bias = torch.rand(2, *size, generator=gen, dtype=dtype) * 0.5
    return [t.requires_grad_(True) for t in (tex, uv, uv_da, bias)]


@pytest.mark.parametrize('filter_mode, boundary, mip_source', list(texture_cases()))
def test_texture_backward_matches_a_contiguous_upstream_for_every_layout(filter_mode, boundary, mip_source):
    tex, uv, uv_da, bias = texture_inputs(boundary)
    inputs = [tex, uv]
    kwargs = dict(filter_mode=filter_mode, boundary_mode=boundary)
    if filter_mode in MIPMAPPED:
        kwargs.update(uv_da=uv_da, mip_level_bias=bias)
        inputs += [uv_da, bias]
    if mip_source == 'texture_construct_mip':
        kwargs['mip'] = dr.texture_construct_mip(tex, cube_mode=boundary == 'cube')
    elif mip_source == 'a list':
        levels = [torch.rand(2, 8, 4, 3, dtype=tex.dtype, requires_grad=True),
                  torch.rand(2, 4, 2, 3, dtype=tex.dtype, requires_grad=True)]
        kwargs['mip'] = levels
        inputs += levels
    out = dr.texture(tex, uv, **kwargs)
    assert_gradients_ignore_upstream_layout([out], inputs)


def test_texture_sum_backward_gives_one_per_sample_and_channel_to_the_texels():
    # The reproduction: 8 x 8 samples x 3 channels, each of weight 1
    # (spread over up to 4 texels: equal to 192 up to rounding).
    gen = torch.Generator().manual_seed(2)
    tex = torch.rand(1, 16, 16, 3, generator=gen, dtype=torch.float64, requires_grad=True)
    uv = torch.rand(1, 8, 8, 2, generator=gen, dtype=torch.float64)
    for filter_mode in ('nearest', 'linear'):
        grad, = torch.autograd.grad(dr.texture(tex, uv, filter_mode=filter_mode).sum(), tex)
        assert grad.sum().item() == pytest.approx(192.0, rel=1e-12)


LARGE_PERMUTED_UPSTREAM = textwrap.dedent("""
    import torch
    import gradraster.torch as dr
    # A 96 MiB upstream gradient (1024 x 1024 samples x 12 float64 channels) as a
    # permuted view of NCHW storage: its contiguous copy is a block of its own.
    gen = torch.Generator().manual_seed(1)
    tex = torch.rand(1, 16, 16, 12, generator=gen, dtype=torch.float64, requires_grad=True)
    uv = torch.rand(1, 1024, 1024, 2, generator=gen, dtype=torch.float64)
    out = dr.texture(tex, uv, filter_mode='linear')
    nchw = torch.rand(1, 12, 1024, 1024, generator=gen, dtype=torch.float64)
    assert nchw.numel() * 8 == 96 << 20
    got, = torch.autograd.grad(out, tex, nchw.permute(0, 2, 3, 1), retain_graph=True)
    want, = torch.autograd.grad(out, tex, nchw.permute(0, 2, 3, 1).contiguous())
    print('equal' if torch.equal(got, want) else 'differ')
""")


def test_a_96_mib_permuted_upstream_gradient_neither_crashes_nor_changes_the_texture_gradient():
    # In a child process, so that a crash is reported as this test's failure.
    run = subprocess.run([sys.executable, '-c', LARGE_PERMUTED_UPSTREAM], capture_output=True, text=True,
                         env=dict(os.environ), timeout=300)
    assert run.returncode == 0, f"exit status {run.returncode}: {run.stderr[-2000:]}"
    assert run.stdout.strip() == 'equal'


# ----------------------------------------------------------------------------
# Saved tensors: a saved_tensors_hooks pair (offloading, compression) may give
# them back with the same values in another memory layout.

def transposed_storage(t):
    """t's values in storage of the reverse axis order (not contiguous unless t has fewer than 2 long axes)."""
    return t.transpose(0, -1).contiguous().transpose(0, -1) if t.dim() >= 2 else t.clone()


def saved_in_another_layout():
    return torch.autograd.graph.saved_tensors_hooks(transposed_storage, lambda t: t)


def gradients_of(program, inputs):
    out = program(*inputs)
    outs = out if isinstance(out, tuple) else (out,)
    grads = [torch.rand(o.shape, generator=torch.Generator().manual_seed(k), dtype=o.dtype)
             for k, o in enumerate(outs)]
    return torch.autograd.grad(outs, inputs, grads, allow_unused=True)


def assert_gradients_ignore_saved_layout(program, inputs):
    want = gradients_of(program, inputs)
    with saved_in_another_layout():
        got = gradients_of(program, inputs)
    for k, (a, b) in enumerate(zip(want, got)):
        assert (a is None) == (b is None) and (a is None or torch.equal(a, b)), f"input {k}"


@pytest.mark.parametrize('mode', ['instanced', 'range'])
def test_rasterize_interpolate_and_the_antialiases_take_saved_tensors_a_hook_gave_back_in_another_layout(glctx, mode):
    pos, tri, ranges = scene(mode)
    attr = torch.rand(pos.shape[-2], 3, dtype=torch.float64, requires_grad=True)

    def program(p, a):
        rast, db = dr.rasterize(glctx, p, tri, (12, 10), ranges=ranges)
        out, da = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
        return dr.antialias(out, rast, p, tri), dr.visibility_antialias(out, rast, p, tri), da
    assert_gradients_ignore_saved_layout(program, [pos, attr])


@pytest.mark.parametrize('filter_mode, boundary, mip_source', list(texture_cases()))
def test_texture_takes_saved_tensors_a_hook_gave_back_in_another_layout(filter_mode, boundary, mip_source):
    tex, uv, uv_da, bias = texture_inputs(boundary)
    levels = [torch.rand(2, 8, 4, 3, dtype=tex.dtype, requires_grad=True),
              torch.rand(2, 4, 2, 3, dtype=tex.dtype, requires_grad=True)]

    def program(t, u, d, b, *m):
        kwargs = dict(filter_mode=filter_mode, boundary_mode=boundary)
        if filter_mode in MIPMAPPED:
            kwargs.update(uv_da=d, mip_level_bias=b)
        if mip_source == 'texture_construct_mip':
            kwargs['mip'] = dr.texture_construct_mip(t, cube_mode=boundary == 'cube')
        elif mip_source == 'a list':
            kwargs['mip'] = list(m)
        return dr.texture(t, u, **kwargs)
    assert_gradients_ignore_saved_layout(program, [tex, uv, uv_da, bias] + (levels if mip_source == 'a list' else []))
