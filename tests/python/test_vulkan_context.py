"""RasterizeVulkanContext: rasterize on a Vulkan device gives the CPU context's rast and rast_db bit for bit, and
so the same gradients, in every batching mode; a nvdiffrast-style pipeline runs unchanged with it. Skipped (with the
reason) where the build has no GPU path or the machine no Vulkan device; CI runs it on Mesa's lavapipe."""
import pytest
import torch

import gradraster.torch as dr
from gradraster import _core

from conftest import random_mesh


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


def test_vulkan_pipeline_gradients_equal_the_cpu_contexts():
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
    assert gp_c.abs().sum() > 0
    assert torch.equal(image_g, image_c) and torch.equal(gp_g, gp_c) and torch.equal(gc_g, gc_c)


def test_vulkan_float64_takes_the_cpu_kernels_with_the_same_result():
    pos, tri = random_mesh(6, images=1, triangles=30, dtype=torch.float64)
    (rast_c, _), (rast_g, _) = rasterize_both(pos, tri, (24, 24))
    assert torch.equal(rast_g, rast_c)


def test_vulkan_depth_peeling_gives_the_cpu_contexts_layers_and_gradients_bit_for_bit():
    pos, tri = random_mesh(6, images=2, triangles=60, dtype=torch.float32)
    attr = torch.rand(pos.shape[1], 3)
    layers, grads = {}, {}
    for name, ctx in (('cpu', dr.RasterizeCpuContext()), ('gpu', vulkan_context())):
        p = pos.clone().requires_grad_(True)
        with dr.DepthPeeler(ctx, p, tri, (24, 24)) as peeler:
            layers[name] = [peeler.rasterize_next_layer() for _ in range(3)]
        loss = sum((k + 1) * dr.interpolate(attr, rast, tri)[0].square().sum() for k, (rast, _) in enumerate(layers[name]))
        grads[name] = torch.autograd.grad(loss, p)[0]
    assert (layers['cpu'][1][0][..., 3] > 0).sum() > 20  # a second layer, so the floors were used
    for (a, _), (b, _) in zip(layers['cpu'], layers['gpu']):
        assert torch.equal(a, b)
    assert torch.equal(grads['cpu'], grads['gpu'])


def test_vulkan_context_refuses_a_cuda_device_argument():
    vulkan_context()
    with pytest.raises(ValueError, match='device'):
        dr.RasterizeVulkanContext(device='cuda')
