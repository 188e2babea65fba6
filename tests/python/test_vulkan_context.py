"""RasterizeVulkanContext: rasterize on a Vulkan device gives the CPU context's rast and rast_db bit for bit, and
interpolate, antialias, visibility_antialias, texture (2D and cube maps) and the rasterize adjoint run there, forward
and backward, when their rast or uv come from the context: values within 1e-6 relative of the CPU context's and
gradients within 1e-5 of the largest (issue 33), on random scenes and hard cases (triangles through the near plane,
slivers, surfaces cutting through each other), bit-identical run to run; tensors that do not come from the context
(sliced, copied, computed by torch) and float64 take the CPU kernels. torch.autograd.gradcheck in float64 checks the
CPU kernels (in test_interpolate.py, test_antialias.py, test_visibility_antialias.py, test_texture.py,
test_rasterize.py): float64 never runs on the device, whose float32 results are compared here with the CPU's float32
results. Skipped (with the reason) where the build has no GPU path or the machine no Vulkan device; CI runs it on
Mesa's lavapipe."""
import pytest
import torch

import gradraster.torch as dr
from gradraster import _core

from conftest import random_mesh

VALUE_RTOL = 1e-6  # of each value, with a floor of VALUE_FLOOR x the largest (values that cancel to ~0)
VALUE_FLOOR = 1e-3
GRAD_RTOL = 1e-5  # of the largest gradient


def vulkan_context():
    if not _core.HAS_VULKAN:
        pytest.skip('built without the Vulkan GPU path')
    try:
        return dr.RasterizeVulkanContext()
    except RuntimeError as e:
        pytest.skip(str(e))


def near_plane_mesh(seed, triangles=40):
    """Random triangles, some with a vertex behind the camera (w < 0) and some beyond the far plane."""
    g = torch.Generator().manual_seed(seed)
    n = 3 * triangles
    w = torch.rand(n, 1, generator=g) * 2.5 - 0.5
    xyz = (torch.rand(n, 3, generator=g) * 2.4 - 1.2) * w.abs()
    pos = torch.cat([xyz[:, :2], xyz[:, 2:] * 1.1, w], -1)[None].contiguous()
    return pos, torch.arange(n, dtype=torch.int32).reshape(triangles, 3)


def rasterize_both(pos, tri, resolution, **kw):
    cpu = dr.rasterize(dr.RasterizeCpuContext(), pos, tri, resolution, **kw)
    gpu = dr.rasterize(vulkan_context(), pos, tri, resolution, **kw)
    return cpu, gpu


def test_the_context_names_its_device_and_is_a_context():
    ctx = vulkan_context()
    assert isinstance(ctx, dr.RasterizeCpuContext) and ctx.vulkan_device not in ('', 'cpu')


@pytest.mark.parametrize('seed', [0, 1])
def test_vulkan_rast_and_rast_db_are_the_cpu_contexts_bit_for_bit(seed):
    pos, tri = random_mesh(seed, images=1, triangles=60, dtype=torch.float32)
    (rast_c, db_c), (rast_g, db_g) = rasterize_both(pos, tri, (48, 64))
    assert (rast_c[..., 3] > 0).sum() > 100
    assert torch.equal(rast_g, rast_c) and torch.equal(db_g, db_c)


def test_vulkan_handles_the_near_plane_like_the_cpu():
    pos, tri = near_plane_mesh(3)
    (rast_c, db_c), (rast_g, db_g) = rasterize_both(pos, tri, (40, 40))
    assert torch.equal(rast_g, rast_c) and torch.equal(db_g, db_c)


def test_vulkan_instanced_and_range_modes_match_the_cpu():
    pos, tri = random_mesh(4, images=3, triangles=30, dtype=torch.float32)
    (rast_c, _), (rast_g, _) = rasterize_both(pos, tri, (32, 24))
    assert torch.equal(rast_g, rast_c)
    flat = pos[0]
    ranges = torch.tensor([[0, 10], [5, 25], [30, 0]], dtype=torch.int32)
    (rast_c, _), (rast_g, _) = rasterize_both(flat, tri, (32, 24), ranges=ranges)
    assert torch.equal(rast_g, rast_c)


def test_vulkan_pipeline_gradients_match_the_cpu_contexts():
    pos, tri = random_mesh(5, images=2, triangles=40, dtype=torch.float32)
    col = torch.rand(pos.shape[1], 3, generator=torch.Generator().manual_seed(9))

    def run(ctx):
        p = pos.clone().requires_grad_(True)
        c = col.clone().requires_grad_(True)
        rast, db = dr.rasterize(ctx, p, tri, (40, 40))
        image, _ = dr.interpolate(c, rast, tri)
        image = dr.antialias(image, rast, p, tri)
        (image ** 2).sum().backward()
        return image, p.grad, c.grad

    image_c, gp_c, gc_c = run(dr.RasterizeCpuContext())
    image_g, gp_g, gc_g = run(vulkan_context())
    assert_values_close(image_g, image_c, 'image')
    assert_grads_close(gp_g, gp_c, 'pos gradient')
    assert_grads_close(gc_g, gc_c, 'colour gradient')


def test_vulkan_float64_takes_the_cpu_kernels_with_the_same_result():
    pos, tri = random_mesh(6, images=1, triangles=30, dtype=torch.float64)
    (rast_c, _), (rast_g, _) = rasterize_both(pos, tri, (24, 24))
    assert torch.equal(rast_g, rast_c)


def test_vulkan_depth_peeling_gives_the_cpu_contexts_layers_bit_for_bit_and_their_gradients():
    pos, tri = random_mesh(6, images=2, triangles=60, dtype=torch.float32)
    attr = torch.rand(pos.shape[1], 3)
    layers, grads = {}, {}
    for name, ctx in (('cpu', dr.RasterizeCpuContext()), ('gpu', vulkan_context())):
        p = pos.clone().requires_grad_(True)
        with dr.DepthPeeler(ctx, p, tri, (24, 24)) as peeler:
            layers[name] = [peeler.rasterize_next_layer() for _ in range(3)]
        loss = sum((k + 1) * dr.interpolate(attr, rast, tri)[0].square().sum()
                   for k, (rast, _) in enumerate(layers[name]))
        grads[name] = torch.autograd.grad(loss, p)[0]
    assert (layers['cpu'][1][0][..., 3] > 0).sum() > 20  # a second layer, so the floors were used
    for (a, _), (b, _) in zip(layers['cpu'], layers['gpu']):
        assert torch.equal(a, b)
    assert_grads_close(grads['gpu'], grads['cpu'], 'pos gradient')


def test_vulkan_context_refuses_a_cuda_device_argument():
    vulkan_context()
    with pytest.raises(ValueError, match='device'):
        dr.RasterizeVulkanContext(device='cuda')


# ---------------------------------------------------------------------------- interpolate, antialias, texture

def assert_values_close(gpu, cpu, what):
    assert gpu.shape == cpu.shape and gpu.dtype == cpu.dtype, what
    if cpu.numel() == 0:
        return
    scale = cpu.abs().max().item()
    bound = VALUE_RTOL * torch.clamp(cpu.abs(), min=VALUE_FLOOR * scale) + 1e-30
    worst = ((gpu - cpu).abs() / bound).max().item()
    assert worst <= 1, f'{what}: off by {worst:.3g} x the tolerance'


def assert_grads_close(gpu, cpu, what):
    assert gpu.shape == cpu.shape, what
    scale = cpu.abs().max().item()
    assert scale > 0, f'{what}: no gradient'
    worst = (gpu - cpu).abs().max().item() / (GRAD_RTOL * scale)
    assert worst <= 1, f'{what}: off by {worst:.3g} x the tolerance'


# ---------------------------------------------------------------------------- scenes

def grid_mesh(seed, images=1, k=6, dtype=torch.float32):
    """Two overlapping bumpy grids of shared vertices (interior edges, silhouettes, occlusion), in perspective."""
    g = torch.Generator().manual_seed(seed)
    poses, tris = [], []
    for layer, (shift, depth) in enumerate(((-0.25, 0.3), (0.3, -0.2))):
        s = torch.linspace(-0.6, 0.6, k + 1)
        y, x = torch.meshgrid(s, s, indexing='ij')
        z = depth + 0.1 * torch.rand(images, k + 1, k + 1, generator=g)
        w = 0.9 + 0.6 * torch.rand(images, k + 1, k + 1, generator=g)
        angle = 0.3 + layer
        xr, yr = x * torch.cos(torch.tensor(angle)) - y * torch.sin(torch.tensor(angle)) + shift, \
            x * torch.sin(torch.tensor(angle)) + y * torch.cos(torch.tensor(angle)) + shift / 2
        pos = torch.stack([xr.expand_as(w) * w, yr.expand_as(w) * w, z * w, w], -1).reshape(images, -1, 4)
        i = torch.arange(k * k)
        r, c = i // k, i % k
        v = r * (k + 1) + c
        quads = torch.stack([torch.stack([v, v + 1, v + k + 1], -1), torch.stack([v + 1, v + k + 2, v + k + 1], -1)], 1)
        tris.append(quads.reshape(-1, 3) + layer * (k + 1) ** 2)
        poses.append(pos)
    return torch.cat(poses, 1).to(dtype).contiguous(), torch.cat(tris).to(torch.int32).contiguous()


def hard_mesh(seed, images=1, triangles=40):
    """Triangles through the near plane (a vertex with w < 0) and beyond the far plane, and slivers (a vertex
    almost on the opposite edge), vertices shared by neighbours in strips."""
    g = torch.Generator().manual_seed(seed)
    n = triangles + 2
    w = torch.rand(images, n, 1, generator=g) * 2.2 - 0.4
    xyz = (torch.rand(images, n, 3, generator=g) * 2.2 - 1.1) * w.abs()
    pos = torch.cat([xyz[..., :2], xyz[..., 2:] * 1.1, w], -1)
    # Slivers: every fourth vertex moved next to the midpoint of the two before it.
    mid = 0.5 * (pos[:, 0:n - 2] + pos[:, 1:n - 1])
    sliver = torch.zeros(n, dtype=torch.bool)
    sliver[2::4] = True
    pos[:, sliver] = mid[:, sliver[2:].nonzero().squeeze(1)] + 1e-4 * pos[:, sliver]
    i = torch.arange(triangles)
    tri = torch.stack([i, i + 1, i + 2], -1).to(torch.int32)
    return pos.contiguous(), tri


SCENES = {
    'random grid': lambda: grid_mesh(1, images=2),
    'near plane and slivers': lambda: hard_mesh(2, images=2),
}


_SHARED = []


def shared_vulkan_context():
    """One Vulkan context for the tests of the ops (lavapipe compiles each context's shaders at their first use)."""
    if not _SHARED:
        _SHARED.append(vulkan_context())
    return _SHARED[0]


def run_both(program):
    """program(glctx) -> tensors, on the CPU context and on the Vulkan one (and how many device calls it made)."""
    cpu = program(dr.RasterizeCpuContext())
    ctx = shared_vulkan_context()
    before = ctx.device_calls
    gpu = program(ctx)
    return cpu, gpu, ctx.device_calls - before


def leaf(t):
    return t.detach().clone().requires_grad_(True)


# ---------------------------------------------------------------------------- the ops

@pytest.mark.parametrize('scene', SCENES)
def test_the_rasterize_adjoint_on_the_device_matches_the_cpu(scene):
    pos, tri = SCENES[scene]()
    wr, wd = torch.rand(2, 40, 56, 4), torch.rand(2, 40, 56, 4)

    def program(glctx):
        p = leaf(pos)
        rast, db = dr.rasterize(glctx, p, tri, (40, 56))
        ((rast[..., :3] * wr[..., :3]).sum() + (db * wd).sum()).backward()
        return rast, db, p.grad

    (rast_c, db_c, g_c), (rast_g, db_g, g_g), calls = run_both(program)
    assert torch.equal(rast_g, rast_c) and torch.equal(db_g, db_c)
    assert_grads_close(g_g, g_c, 'pos gradient')
    assert calls == 2 + 2  # per image: the G-buffer, the adjoint


def test_the_rasterize_adjoint_in_range_mode_on_the_device_matches_the_cpu():
    pos, tri = grid_mesh(3)
    ranges = torch.tensor([[0, 72], [50, 94], [100, 0]], dtype=torch.int32)
    wr = torch.rand(3, 32, 32, 4)

    def program(glctx):
        p = leaf(pos[0])
        rast, db = dr.rasterize(glctx, p, tri, (32, 32), ranges=ranges)
        ((rast * wr).sum() + db.square().sum()).backward()
        return rast, p.grad

    (rast_c, g_c), (rast_g, g_g), calls = run_both(program)
    assert torch.equal(rast_g, rast_c)
    assert_grads_close(g_g, g_c, 'pos gradient')
    assert calls == 3 + 3


@pytest.mark.parametrize('scene', SCENES)
@pytest.mark.parametrize('diff_attrs', [None, 'all', [2, 0]])
@pytest.mark.parametrize('attr_images', [0, 1, 2])  # 0: attr [N, C]; 1: broadcast [1, N, C]; 2: per image
def test_interpolate_on_the_device_matches_the_cpu_with_its_derivatives_and_gradients(scene, diff_attrs, attr_images):
    pos, tri = SCENES[scene]()
    shape = (pos.shape[1], 3) if attr_images == 0 else (attr_images, pos.shape[1], 3)
    attr = torch.rand(shape) * 2 - 0.5
    w_out, w_da = torch.rand(2, 36, 44, 3), torch.rand(2, 36, 44, 6)

    def program(glctx):
        p, a = leaf(pos), leaf(attr)
        rast, db = dr.rasterize(glctx, p, tri, (36, 44))
        out, da = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs=diff_attrs)
        ((out * w_out).sum() + (da * w_da[..., :da.shape[-1]]).sum()).backward()
        return out, da, a.grad, p.grad

    cpu, gpu, calls = run_both(program)
    for name, g, c in zip(('out', 'out_da'), gpu[:2], cpu[:2]):
        assert_values_close(g, c, name)
    for name, g, c in zip(('attr gradient', 'pos gradient'), gpu[2:], cpu[2:]):
        assert_grads_close(g, c, name)
    assert calls == 2 * 4  # per image: rasterize, interpolate, its adjoint, rasterize's adjoint



def test_interpolate_of_attributes_with_no_channels_runs_on_the_device_and_its_adjoint_gives_zero_gradients():
    pos, tri = grid_mesh(3, images=2)

    def program(glctx):
        p, a = leaf(pos), leaf(torch.rand(pos.shape[1], 0))
        rast, db = dr.rasterize(glctx, p, tri, (36, 44))
        out, da = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
        (out.sum() + da.sum() + rast[..., :3].sum()).backward()
        return out, da, a.grad, p.grad

    cpu, gpu, calls = run_both(program)
    assert gpu[0].shape == (2, 36, 44, 0) and gpu[1].shape == (2, 36, 44, 0) and gpu[2].shape == (pos.shape[1], 0)
    assert_grads_close(gpu[3], cpu[3], 'pos gradient')  # from rast's own channels alone
    assert calls == 2 * 4  # per image: rasterize, interpolate, its adjoint, rasterize's adjoint

@pytest.mark.parametrize('scene', SCENES)
@pytest.mark.parametrize('boost', [1.0, 2.5])
def test_antialias_on_the_device_matches_the_cpu_with_gradients_to_color_and_pos(scene, boost):
    pos, tri = SCENES[scene]()
    attr = torch.rand(pos.shape[1], 4)
    w = torch.rand(2, 40, 48, 4)
    topology = dr.antialias_construct_topology_hash(tri)

    def program(glctx):
        p, a = leaf(pos), leaf(attr)
        rast, _ = dr.rasterize(glctx, p, tri, (40, 48))
        color, _ = dr.interpolate(a, rast, tri)
        out = dr.antialias(color, rast, p, tri, topology_hash=topology, pos_gradient_boost=boost)
        (out * w).sum().backward()
        return out, a.grad, p.grad

    (out_c, ga_c, gp_c), (out_g, ga_g, gp_g), calls = run_both(program)
    assert_values_close(out_g, out_c, 'antialiased colour')
    assert not torch.equal(out_c, dr.interpolate(attr, dr.rasterize(dr.RasterizeCpuContext(), pos, tri, (40, 48))[0],
                                                 tri)[0]), 'no edge was blended'
    assert_grads_close(ga_g, ga_c, 'attr gradient (through colour)')
    assert_grads_close(gp_g, gp_c, 'pos gradient')
    assert calls == 2 * 6


def test_antialias_with_pos_shared_by_the_images_on_the_device_matches_the_cpu():
    pos, tri = grid_mesh(5)
    color_of = torch.rand(pos.shape[1], 2)

    def program(glctx):
        p, a = leaf(pos[0]), leaf(color_of)
        ranges = torch.tensor([[0, tri.shape[0]]] * 2, dtype=torch.int32)
        rast, _ = dr.rasterize(glctx, p, tri, (32, 40), ranges=ranges)
        color, _ = dr.interpolate(a, rast, tri)
        out = dr.antialias(color, rast, p, tri)
        out.square().sum().backward()
        return out, a.grad, p.grad

    (out_c, ga_c, gp_c), (out_g, ga_g, gp_g), calls = run_both(program)
    assert_values_close(out_g, out_c, 'antialiased colour')
    assert_grads_close(ga_g, ga_c, 'attr gradient')
    assert_grads_close(gp_g, gp_c, 'pos gradient')
    assert calls == 2 * 6


TEXTURE_CASES = [
    ('nearest', 'wrap', None), ('linear', 'wrap', None), ('linear', 'clamp', None), ('linear', 'zero', None),
    ('linear-mipmap-linear', 'wrap', 'auto'), ('linear-mipmap-linear', 'clamp', 'prebuilt'),
    ('linear-mipmap-nearest', 'zero', 'auto'), ('linear-mipmap-linear', 'wrap', 'user'),
    ('linear-mipmap-linear', 'wrap', 'bias'),
]


@pytest.mark.parametrize('scene', SCENES)
@pytest.mark.parametrize('filter_mode, boundary, mip', TEXTURE_CASES)
def test_texture_with_uv_from_interpolate_runs_on_the_device_and_matches_the_cpu(scene, filter_mode, boundary, mip):
    pos, tri = SCENES[scene]()
    uv_attr = torch.rand(pos.shape[1], 2) * 3 - 1  # beyond [0, 1]: the boundary mode matters
    tex = torch.rand(1, 16, 24, 3)
    levels = [torch.rand(1, 8, 12, 3), torch.rand(1, 4, 6, 3)]
    bias = torch.rand(2, 36, 40) * 2 - 0.5
    w = torch.rand(2, 36, 40, 3)

    def program(glctx):
        p, a, t = leaf(pos), leaf(uv_attr), leaf(tex)
        user = [leaf(m) for m in levels]
        b = leaf(bias)
        rast, db = dr.rasterize(glctx, p, tri, (36, 40))
        uv, uv_da = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
        kw = {}
        if mip == 'prebuilt':
            kw['mip'] = dr.texture_construct_mip(t)
        elif mip == 'user':
            kw['mip'] = user
        elif mip == 'bias':
            kw['mip_level_bias'] = b
        out = dr.texture(t, uv, uv_da if mip != 'bias' else None, filter_mode=filter_mode, boundary_mode=boundary,
                         **kw)
        (out * w).sum().backward()
        grads = {'tex': t.grad, 'uv attr': a.grad, 'pos': p.grad}
        if mip == 'user':
            grads['mip level 1'] = user[0].grad
        if mip == 'bias':
            grads['bias'] = b.grad
        return out, grads

    (out_c, grads_c), (out_g, grads_g), calls = run_both(program)
    assert_values_close(out_g, out_c, 'texture samples')
    for name, c in grads_c.items():
        if filter_mode == 'nearest' and name != 'tex':  # nearest: no uv gradient
            assert grads_g[name].abs().max() == 0 and c.abs().max() == 0
            continue
        assert_grads_close(grads_g[name], c, name + ' gradient')
    assert calls == 2 * 6


@pytest.mark.parametrize('mip', [None, 'auto', 'user'])
def test_texture_backward_on_the_device_reads_the_texels_its_forward_kept(mip):
    pos, tri = SCENES[next(iter(SCENES))]()
    uv_attr = torch.rand(pos.shape[1], 2)
    tex, levels = leaf(torch.rand(1, 16, 24, 3)), [leaf(torch.rand(1, 8, 12, 3)), leaf(torch.rand(1, 4, 6, 3))]

    def program(glctx):
        rast, db = dr.rasterize(glctx, pos, tri, (36, 40))
        uv, uv_da = dr.interpolate(uv_attr, rast, tri, rast_db=db, diff_attrs='all')
        kw = {'mip': levels} if mip == 'user' else {}
        mode = 'linear' if mip is None else 'linear-mipmap-linear'
        out = dr.texture(tex, uv, uv_da, filter_mode=mode, **kw)
        out.square().sum().backward()
        return out, tex.grad.clone()

    ctx = shared_vulkan_context()
    before = ctx.texture_residency
    out_g, g_g = program(ctx)
    after = ctx.texture_residency
    # One texture shared by the 2 images: uploaded once, read from the device by the other 3 calls.
    assert after['uploads'] - before['uploads'] == 1
    assert after['resident_calls'] - before['resident_calls'] == 3
    # Level 0 and the user's 2 levels; or level 0 alone: the device builds the chain from it.
    upper = [(8, 12), (4, 6)] if mip == 'user' else []
    texels = 16 * 24 + sum(h * w for h, w in upper)
    assert after['upload_bytes'] - before['upload_bytes'] == texels * 3 * 4
    tex.grad = None
    out_c, g_c = program(dr.RasterizeCpuContext())
    assert_values_close(out_g, out_c, 'texture samples')
    assert_grads_close(g_g, g_c, 'tex gradient')


@pytest.mark.parametrize('filter_mode', ['nearest', 'linear', 'linear-mipmap-linear', 'linear-mipmap-nearest'])
def test_cube_map_texture_with_directions_from_interpolate_runs_on_the_device_and_matches_the_cpu(filter_mode):
    pos, tri = grid_mesh(7, images=2)
    dirs = torch.randn(pos.shape[1], 3)
    faces = torch.rand(2, 6, 16, 16, 3)
    w = torch.rand(2, 32, 32, 3)
    mipmapped = 'mipmap' in filter_mode

    def program(glctx):
        p, d, f = leaf(pos), leaf(dirs), leaf(faces)
        rast, db = dr.rasterize(glctx, p, tri, (32, 32))
        uv, uv_da = dr.interpolate(d, rast, tri, rast_db=db, diff_attrs='all')
        out = dr.texture(f, uv, uv_da if mipmapped else None, filter_mode=filter_mode, boundary_mode='cube')
        (out * w).sum().backward()
        return out, f.grad, d.grad, p.grad

    (out_c, *g_c), (out_g, *g_g), calls = run_both(program)
    assert_values_close(out_g, out_c, 'cube map samples')
    for name, g, c in zip(('faces', 'direction attr', 'pos'), g_g, g_c):
        if filter_mode == 'nearest' and name != 'faces':
            continue
        assert_grads_close(g, c, name + ' gradient')
    assert calls == 2 * 6


def test_depth_peeled_layers_feed_interpolate_and_antialias_on_the_device():
    pos, tri = grid_mesh(8, images=2)
    attr = torch.rand(pos.shape[1], 3)

    def program(glctx):
        p, a = leaf(pos), leaf(attr)
        outs = []
        with dr.DepthPeeler(glctx, p, tri, (32, 32)) as peeler:
            for _ in range(2):
                rast, db = peeler.rasterize_next_layer()
                color, _ = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
                outs.append(dr.antialias(color, rast, p, tri))
        sum((k + 1) * o.square().sum() for k, o in enumerate(outs)).backward()
        return outs[0], outs[1], a.grad, p.grad

    (*out_c, ga_c, gp_c), (*out_g, ga_g, gp_g), calls = run_both(program)
    assert (out_c[1] != 0).any()  # a second layer
    for k in range(2):
        assert_values_close(out_g[k], out_c[k], f'layer {k}')
    assert_grads_close(ga_g, ga_c, 'attr gradient')
    assert_grads_close(gp_g, gp_c, 'pos gradient')
    assert calls == 2 * 2 * 6


def nvdiffrast_program(glctx, pos, tri, uv_attr, tex):
    """nvdiffrast's texture sample's shape: rasterize -> interpolate with diff_attrs -> texture with mip ->
    antialias -> loss.backward, as written for nvdiffrast but for the context."""
    pos, uv_attr, tex = leaf(pos), leaf(uv_attr), leaf(tex)
    rast, rast_db = dr.rasterize(glctx, pos, tri, resolution=[48, 48])
    texc, texd = dr.interpolate(uv_attr[None, ...], rast, tri, rast_db=rast_db, diff_attrs='all')
    color = dr.texture(tex, texc, texd, filter_mode='linear-mipmap-linear', max_mip_level=3)
    color = color * torch.clamp(rast[..., -1:], 0, 1)  # mask out the background
    color = dr.antialias(color, rast, pos, tri)
    loss = (color - 0.5).square().mean()
    loss.backward()
    return color, pos.grad, uv_attr.grad, tex.grad


def test_an_nvdiffrast_program_gives_the_cpu_contexts_image_and_gradients_on_the_device():
    pos, tri = grid_mesh(9, images=2)
    uv_attr, tex = torch.rand(pos.shape[1], 2), torch.rand(1, 32, 32, 3)
    ctx = vulkan_context()  # its own: device_calls counts this program's calls
    cpu = nvdiffrast_program(dr.RasterizeCpuContext(), pos, tri, uv_attr, tex)
    gpu = nvdiffrast_program(ctx, pos, tri, uv_attr, tex)
    assert ctx.device_calls == 2 * 8  # per image: rasterize, interpolate, texture, antialias; their adjoints
    assert_values_close(gpu[0], cpu[0], 'image')
    for name, g, c in zip(('pos', 'uv', 'tex'), gpu[1:], cpu[1:]):
        assert_grads_close(g, c, name + ' gradient')


def test_the_device_gives_the_same_bits_run_to_run():
    pos, tri = hard_mesh(10, images=2)
    uv_attr, tex = torch.rand(pos.shape[1], 2), torch.rand(1, 32, 32, 3)
    ctx = shared_vulkan_context()
    first = nvdiffrast_program(ctx, pos, tri, uv_attr, tex)
    again = nvdiffrast_program(ctx, pos, tri, uv_attr, tex)
    other = nvdiffrast_program(vulkan_context(), pos, tri, uv_attr, tex)  # a fresh context and frame
    for a, b, c in zip(first, again, other):
        assert torch.equal(a, b) and torch.equal(a, c)


# ---------------------------------------------------------------------------- what stays on the CPU

def test_a_sliced_copied_or_computed_rast_runs_on_the_cpu_kernels():
    pos, tri = grid_mesh(11, images=2)
    attr = torch.rand(pos.shape[1], 3)
    ctx = vulkan_context()
    rast, db = dr.rasterize(ctx, pos, tri, (24, 24))
    want, _ = dr.interpolate(attr, rast, tri)
    for other in (rast[:1], rast.clone(), rast.detach(), rast + 0):
        before = ctx.device_calls
        out, _ = dr.interpolate(attr, other, tri)
        aa = dr.antialias(out, other, pos[:out.shape[0]], tri)
        assert ctx.device_calls == before  # on the CPU kernels
        assert_values_close(out, want[:out.shape[0]], 'interpolate of a rast not from the context')
        assert aa.shape == out.shape
    before = ctx.device_calls
    dr.interpolate(attr, rast, tri)
    assert ctx.device_calls == before + 2  # the very tensor: on the device


def test_texture_runs_on_the_cpu_unless_uv_is_interpolates_own_output():
    pos, tri = grid_mesh(12)
    ctx = vulkan_context()
    rast, db = dr.rasterize(ctx, pos, tri, (24, 24))
    uv, uv_da = dr.interpolate(torch.rand(pos.shape[1], 2), rast, tri, rast_db=db, diff_attrs='all')
    tex = torch.rand(1, 8, 8, 3)
    before = ctx.device_calls
    on_device = dr.texture(tex, uv, uv_da, filter_mode='linear-mipmap-linear')
    assert ctx.device_calls == before + 1
    for computed in (uv * 1, uv.clone(), uv[..., :2].contiguous()):
        before = ctx.device_calls
        out = dr.texture(tex, computed, uv_da, filter_mode='linear-mipmap-linear')
        assert ctx.device_calls == before
        assert_values_close(out, on_device, 'texture on the CPU kernels')
    # A CPU context's uv never reaches a device.
    rast_c, db_c = dr.rasterize(dr.RasterizeCpuContext(), pos, tri, (24, 24))
    uv_c, _ = dr.interpolate(torch.rand(pos.shape[1], 2), rast_c, tri)
    before = ctx.device_calls
    dr.texture(tex, uv_c)
    assert ctx.device_calls == before


def test_float64_runs_on_the_cpu_kernels_and_visibility_antialias_on_the_device():
    pos, tri = grid_mesh(13, dtype=torch.float64)
    attr = torch.rand(pos.shape[1], 3, dtype=torch.float64)
    ctx = vulkan_context()
    p = leaf(pos)
    rast, db = dr.rasterize(ctx, p, tri, (24, 24))
    out, _ = dr.interpolate(attr, rast, tri)
    dr.antialias(out, rast, p, tri).sum().backward()
    assert ctx.device_calls == 0
    p32 = leaf(pos.float())
    rast, _ = dr.rasterize(ctx, p32, tri, (24, 24))
    before = ctx.device_calls
    out, _ = dr.interpolate(attr.float(), rast, tri)
    assert ctx.device_calls == before + 1
    dr.visibility_antialias(out, rast, p32, tri).sum().backward()
    # visibility_antialias and its adjoint, interpolate's adjoint and rasterize's.
    assert ctx.device_calls == before + 1 + 2 + 1 + 1


def interpenetrating_mesh(seed, images=2, triangles=8):
    """Large triangles at random depths cutting through each other (intersection curves), in perspective."""
    g = torch.Generator().manual_seed(seed)
    n = 3 * triangles
    w = 0.8 + 0.5 * torch.rand(images, n, 1, generator=g)
    xy = (torch.rand(images, n, 2, generator=g) * 1.8 - 0.9) * w
    z = (torch.rand(images, n, 1, generator=g) * 1.2 - 0.6) * w
    return torch.cat([xy, z, w], -1).contiguous(), torch.arange(n, dtype=torch.int32).reshape(triangles, 3)


@pytest.mark.parametrize('scene', ['interpenetrating', 'random grid'])
@pytest.mark.parametrize('boost', [1.0, 2.5])
def test_visibility_antialias_on_the_device_matches_the_cpu_with_gradients_to_color_and_pos(scene, boost):
    pos, tri = interpenetrating_mesh(7) if scene == 'interpenetrating' else grid_mesh(1, images=2)
    attr = torch.rand(pos.shape[1], 3)
    w = torch.rand(2, 40, 48, 3)

    def program(glctx):
        p, a = leaf(pos), leaf(attr)
        rast, _ = dr.rasterize(glctx, p, tri, (40, 48))
        color, _ = dr.interpolate(a, rast, tri)
        out = dr.visibility_antialias(color, rast, p, tri, pos_gradient_boost=boost)
        (out * w).sum().backward()
        return out, a.grad, p.grad

    (out_c, ga_c, gp_c), (out_g, ga_g, gp_g), calls = run_both(program)
    assert_values_close(out_g, out_c, 'antialiased colour')
    if scene == 'interpenetrating':  # crossings blended: not what antialias gives
        rast_c, _ = dr.rasterize(dr.RasterizeCpuContext(), pos, tri, (40, 48))
        color_c, _ = dr.interpolate(attr, rast_c, tri)
        assert not torch.equal(out_c, dr.antialias(color_c, rast_c, pos, tri)), 'no intersection was blended'
    assert_grads_close(ga_g, ga_c, 'attr gradient (through colour)')
    assert_grads_close(gp_g, gp_c, 'pos gradient')
    assert calls == 2 * 6
    _, again, _ = run_both(program)
    assert torch.equal(again[0], out_g) and torch.equal(again[2], gp_g)


def test_saving_or_copying_a_rast_from_the_device_keeps_no_context():
    import copy
    import io
    pos, tri = grid_mesh(14)
    rast, _ = dr.rasterize(vulkan_context(), pos, tri, (16, 16))
    buffer = io.BytesIO()
    torch.save(rast, buffer)
    buffer.seek(0)
    assert torch.equal(torch.load(buffer), rast)
    assert torch.equal(copy.deepcopy(rast), rast)
