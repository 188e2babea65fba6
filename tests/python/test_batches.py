"""Instanced and range modes: one call equals separate calls, bit for bit, values and gradients."""
import torch

import gradraster.torch as dr
from conftest import random_mesh


def render(glctx, pos, tri, ranges=None, attr=None):
    rast, db = dr.rasterize(glctx, pos, tri, (20, 16), ranges=ranges)
    out, da = dr.interpolate(attr, rast, tri, db, diff_attrs='all')
    return dr.antialias(out, rast, pos, tri), da


def test_instanced_mode_equals_one_call_per_image(glctx):
    pos, tri = random_mesh(11, images=3, triangles=8, requires_grad=True)
    attr = torch.randn(3, pos.shape[1], 2, dtype=torch.float64, requires_grad=True)
    w = torch.randn(3, 20, 16, 2, dtype=torch.float64)
    img, da = render(glctx, pos, tri, attr=attr)
    gp, ga = torch.autograd.grad((img * w).sum() + da.sum(), (pos, attr))
    for b in range(3):
        p = pos[b:b + 1].detach().requires_grad_(True)
        a = attr[b:b + 1].detach().requires_grad_(True)
        img_b, da_b = render(glctx, p, tri, attr=a)
        assert torch.equal(img_b[0], img[b]) and torch.equal(da_b[0], da[b])
        gp_b, ga_b = torch.autograd.grad((img_b * w[b:b + 1]).sum() + da_b.sum(), (p, a))
        assert torch.equal(gp_b[0], gp[b]) and torch.equal(ga_b[0], ga[b])


def test_range_mode_draws_each_images_range_with_global_triangle_ids(glctx):
    pos3, tri = random_mesh(12, triangles=9)
    pos = pos3[0]
    ranges = torch.tensor([[0, 3], [3, 6], [2, 0]], dtype=torch.int32)
    rast, _ = dr.rasterize(glctx, pos, tri, (20, 16), ranges=ranges)
    for b, (first, count) in enumerate(ranges.tolist()):
        alone, _ = dr.rasterize(glctx, pos[None], tri[first:first + count], (20, 16))
        ids = alone[0, ..., 3]
        assert torch.equal(rast[b, ..., 3], torch.where(ids > 0, ids + first, ids))
        assert torch.equal(rast[b, ..., :3], alone[0, ..., :3])
    assert torch.count_nonzero(rast[2]) == 0  # an empty range draws nothing


def test_range_mode_gradients_sum_over_images_in_order(glctx):
    pos3, tri = random_mesh(13, triangles=6)
    pos = pos3[0].clone().requires_grad_(True)
    attr = torch.randn(pos.shape[0], 3, dtype=torch.float64, requires_grad=True)
    ranges = torch.tensor([[0, 4], [2, 4]], dtype=torch.int32)
    img, da = render(glctx, pos, tri, ranges=ranges, attr=attr)
    gp, ga = torch.autograd.grad(img.sum() + da.sum(), (pos, attr))
    expect_p, expect_a = torch.zeros_like(pos), torch.zeros_like(attr)
    for b in range(2):
        img_b, da_b = render(glctx, pos, tri, ranges=ranges[b:b + 1], attr=attr)
        g = torch.autograd.grad(img_b.sum() + da_b.sum(), (pos, attr))
        expect_p, expect_a = expect_p + g[0], expect_a + g[1]
    # The two sums add the same per-image terms in another grouping (per op, then per image), so
    # they agree to rounding relative to the terms' size, not to the (possibly cancelled) result.
    for got, expect in ((gp, expect_p), (ga, expect_a)):
        assert torch.allclose(got, expect, rtol=0, atol=1e-13 * expect.abs().max())


def test_attr_with_minibatch_one_broadcasts_over_images(glctx):
    pos, tri = random_mesh(14, images=2, triangles=5)
    attr = torch.randn(1, pos.shape[1], 3, dtype=torch.float64)
    rast, _ = dr.rasterize(glctx, pos, tri, (20, 16))
    a, _ = dr.interpolate(attr, rast, tri)
    b, _ = dr.interpolate(attr.expand(2, -1, -1).contiguous(), rast, tri)
    assert torch.equal(a, b)
