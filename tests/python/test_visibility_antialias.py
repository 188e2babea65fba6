"""visibility_antialias: antialias at every visibility boundary, intersection curves included."""
import pytest
import torch
from torch.autograd import gradcheck

import gradraster.torch as dr
from conftest import random_mesh, two_triangles


def crossing_triangles(requires_grad=False):
    """Triangle 0 at depth 0; triangle 1 tilted (z = 0.6 (x - 0.13) + 0.05 y) cuts through it
    along a line near x = 0.13 that passes through no pixel centre at 16 x 14."""
    def z(x, y):
        return 0.6 * (x - 0.13) + 0.05 * y
    flat = [[-0.9, -0.9, 0.0, 1.0], [0.9, -0.85, 0.0, 1.0], [0.05, 0.9, 0.0, 1.0]]
    tilted = [[x, y, z(x, y), 1.0] for x, y in ((-0.7, -0.8), (0.8, -0.6), (0.1, 0.8))]
    pos = torch.tensor([flat + tilted], dtype=torch.float64)
    tri = torch.tensor([[0, 1, 2], [3, 4, 5]], dtype=torch.int32)
    return pos.requires_grad_(requires_grad), tri


def weighted_sum_grads(op, color, rast, pos, tri, weights):
    out = op(color, rast, pos, tri)
    return (out,) + torch.autograd.grad((out * weights).sum(), (color, pos))


def test_equals_antialias_bit_for_bit_where_nothing_interpenetrates(glctx):
    pos, tri = two_triangles(requires_grad=True)
    rast, _ = dr.rasterize(glctx, pos.detach(), tri, (16, 14))
    color = torch.randn(1, 16, 14, 3, dtype=torch.float64, requires_grad=True)
    weights = torch.randn(1, 16, 14, 3, dtype=torch.float64)
    ours = weighted_sum_grads(dr.visibility_antialias, color, rast, pos, tri, weights)
    plain = weighted_sum_grads(dr.antialias, color, rast, pos, tri, weights)
    assert torch.count_nonzero(ours[2]) > 0
    for a, b in zip(ours, plain):
        assert torch.equal(a, b)


def test_an_intersection_curve_is_blended_and_its_depth_gradient_reaches_both_triangles(glctx):
    pos, tri = crossing_triangles(requires_grad=True)
    rast, _ = dr.rasterize(glctx, pos.detach(), tri, (16, 14))
    ids = rast[0, ..., 3]
    assert (ids == 1).any() and (ids == 2).any()
    color = torch.stack([(ids == 1).double(), (ids == 2).double()], -1)[None].requires_grad_(True)
    weights = torch.ones(1, 16, 14, 2, dtype=torch.float64)
    weights[..., 1] = -1
    vis, _, g_vis = weighted_sum_grads(dr.visibility_antialias, color, rast, pos, tri, weights)
    aa, _, g_aa = weighted_sum_grads(dr.antialias, color, rast, pos, tri, weights)
    # Pixels only visibility_antialias changes lie where both triangles meet, away from the background.
    changed = (vis != aa).any(-1)[0]
    assert changed.any()
    for r, c in changed.nonzero().tolist():
        neighbours = {int(ids[rr, cc]) for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1))
                      if 0 <= rr < 16 and 0 <= cc < 14}
        assert int(ids[r, c]) in (1, 2) and {1, 2} <= neighbours | {int(ids[r, c])}
    # With w = 1 the silhouettes do not depend on z: antialias gives z no gradient,
    # visibility_antialias moves the intersection through both triangles' depths.
    assert torch.count_nonzero(g_aa[0, :, 2]) == 0
    assert torch.count_nonzero(g_vis[0, :3, 2]) > 0 and torch.count_nonzero(g_vis[0, 3:, 2]) > 0


def test_gradients_at_an_intersection_match_finite_differences(glctx):
    pos, tri = crossing_triangles(requires_grad=True)
    rast, _ = dr.rasterize(glctx, pos.detach(), tri, (16, 14))
    color = torch.randn(1, 16, 14, 2, dtype=torch.float64, requires_grad=True)
    assert gradcheck(lambda c, p: dr.visibility_antialias(c, rast, p, tri), (color, pos), eps=1e-6, atol=1e-8)


# Random triangles at random depths: every seed below 12 whose image shows an
# intersection curve (the others have none in view).
@pytest.mark.parametrize('seed', [0, 2, 3, 5, 8, 10])
def test_gradients_on_random_interpenetrating_triangles_match_finite_differences(glctx, seed):
    pos, tri = random_mesh(seed, triangles=4, requires_grad=True)
    rast, _ = dr.rasterize(glctx, pos.detach(), tri, (16, 14))
    color = torch.randn(1, 16, 14, 2, dtype=torch.float64, requires_grad=True)
    # The scene has intersection curves that antialias does not blend.
    assert not torch.equal(dr.visibility_antialias(color, rast, pos, tri), dr.antialias(color, rast, pos, tri))
    assert gradcheck(lambda c, p: dr.visibility_antialias(c, rast, p, tri), (color, pos), eps=1e-6, atol=1e-8)


def test_a_batch_gives_what_each_image_gives_alone(glctx):
    pos, tri = random_mesh(7, images=3, triangles=5, requires_grad=True)
    rast, _ = dr.rasterize(glctx, pos.detach(), tri, (12, 10))
    color = torch.randn(3, 12, 10, 3, dtype=torch.float64, requires_grad=True)
    weights = torch.randn(3, 12, 10, 3, dtype=torch.float64)
    out, g_color, g_pos = weighted_sum_grads(dr.visibility_antialias, color, rast, pos, tri, weights)
    for b in range(3):
        one = weighted_sum_grads(dr.visibility_antialias, color[b:b + 1].detach().requires_grad_(True),
                                 rast[b:b + 1], pos[b:b + 1].detach().requires_grad_(True), tri, weights[b:b + 1])
        assert torch.equal(out[b:b + 1], one[0])
        assert torch.equal(g_color[b:b + 1], one[1])
        assert torch.equal(g_pos[b:b + 1], one[2])


def test_pos_gradient_boost_scales_only_the_position_gradient(glctx):
    pos, tri = crossing_triangles(requires_grad=True)
    rast, _ = dr.rasterize(glctx, pos.detach(), tri, (16, 14))
    color = torch.randn(1, 16, 14, 3, dtype=torch.float64, requires_grad=True)
    w = torch.randn(1, 16, 14, 3, dtype=torch.float64)
    (gp1, gc1), (gp3, gc3) = [
        torch.autograd.grad((dr.visibility_antialias(color, rast, pos, tri, pos_gradient_boost=boost) * w).sum(),
                            (pos, color)) for boost in (1.0, 3.0)]
    assert torch.count_nonzero(gp1) > 0
    assert torch.allclose(gp3, 3.0 * gp1, rtol=1e-15, atol=0)
    assert torch.equal(gc3, gc1)


def test_bad_input_is_refused_with_the_name_of_the_argument(glctx):
    pos, tri = crossing_triangles()
    rast, _ = dr.rasterize(glctx, pos, tri, (16, 14))
    color = torch.zeros(1, 16, 14, 3, dtype=torch.float64)
    with pytest.raises(ValueError, match="'color'"):
        dr.visibility_antialias(color[:, :8], rast, pos, tri)
    with pytest.raises(ValueError, match="'pos_gradient_boost'"):
        dr.visibility_antialias(color, rast, pos, tri, pos_gradient_boost=float('nan'))
    with pytest.raises(TypeError, match="'topology_hash'"):
        dr.visibility_antialias(color, rast, pos, tri, topology_hash=object())
    with pytest.raises(ValueError, match="visibility_antialias: 'topology_hash'"):
        other = torch.tensor([[0, 1, 2]], dtype=torch.int32)
        dr.visibility_antialias(color, rast, pos, tri, topology_hash=dr.antialias_construct_topology_hash(other))
