"""antialias: silhouette blending and its gradients to colour and positions."""
import pytest
import torch
from torch.autograd import gradcheck

import gradraster.torch as dr
from conftest import random_mesh, two_triangles


def test_only_pixels_next_to_a_silhouette_change(glctx):
    pos, tri = two_triangles()
    rast, _ = dr.rasterize(glctx, pos, tri, (24, 20))
    color = torch.ones(1, 24, 20, 1, dtype=torch.float64) * (rast[..., 3:] > 0)
    out = dr.antialias(color, rast, pos, tri)
    changed = (out != color)[0, ..., 0]
    covered = rast[0, ..., 3] > 0
    # Every changed pixel has a neighbour of the other coverage.
    pad = torch.nn.functional.pad(covered[None, None].double(), (1, 1, 1, 1), mode='replicate')[0, 0]
    boundary = torch.zeros_like(covered)
    for dy, dx in ((0, 1), (2, 1), (1, 0), (1, 2)):
        boundary |= pad[dy:dy + 24, dx:dx + 20].bool() != covered
    assert changed.any() and not (changed & ~boundary).any()
    # The interior edge shared by the two triangles is not a silhouette: interior colour unchanged.
    assert torch.equal(out[0][covered & ~boundary], color[0][covered & ~boundary])


# Seeds whose pixel centres are not within 1e-6 of an edge (where eps would cross it).
@pytest.mark.parametrize('seed', [2, 4])
def test_gradients_to_color_and_pos_match_finite_differences(glctx, seed):
    pos, tri = random_mesh(seed, triangles=4, requires_grad=True)
    rast, _ = dr.rasterize(glctx, pos.detach(), tri, (16, 14))
    color = torch.randn(1, 16, 14, 2, dtype=torch.float64, requires_grad=True)
    assert gradcheck(lambda c, p: dr.antialias(c, rast, p, tri), (color, pos), eps=1e-6, atol=1e-8)


def test_pos_gradient_boost_scales_only_the_position_gradient(glctx):
    pos, tri = two_triangles(requires_grad=True)
    rast, _ = dr.rasterize(glctx, pos.detach(), tri, (16, 14))
    color = torch.randn(1, 16, 14, 3, dtype=torch.float64, requires_grad=True)
    w = torch.randn(1, 16, 14, 3, dtype=torch.float64)
    grads = []
    for boost in (1.0, 3.0):
        gp, gc = torch.autograd.grad((dr.antialias(color, rast, pos, tri, pos_gradient_boost=boost) * w).sum(),
                                     (pos, color))
        grads.append((gp, gc))
    assert torch.count_nonzero(grads[0][0]) > 0
    assert torch.allclose(grads[1][0], 3.0 * grads[0][0], rtol=1e-15, atol=0)
    assert torch.equal(grads[1][1], grads[0][1])


def test_a_prebuilt_topology_hash_gives_the_same_result(glctx):
    pos, tri = two_triangles()
    rast, _ = dr.rasterize(glctx, pos, tri, (16, 14))
    color = torch.randn(1, 16, 14, 3, dtype=torch.float64)
    topology = dr.antialias_construct_topology_hash(tri)
    assert torch.equal(dr.antialias(color, rast, pos, tri, topology_hash=topology),
                       dr.antialias(color, rast, pos, tri))
