"""Double backward: every op's backward is once-differentiable, so create_graph=True raises instead of
silently giving a gradient with no graph (a gradient penalty would be zero)."""
import pytest
import torch

import gradraster.torch as dr
from conftest import random_mesh


def scene(glctx):
    pos, tri = random_mesh(2, images=1, triangles=8, requires_grad=True)
    rast, db = dr.rasterize(glctx, pos, tri, (12, 12))
    return pos, tri, rast, db


def rasterize_loss(glctx):
    pos, tri, rast, db = scene(glctx)
    return (rast ** 2).sum() + (db ** 2).sum(), pos


def interpolate_loss(glctx):
    pos, tri, rast, db = scene(glctx)
    attr = torch.rand(1, pos.shape[1], 2, dtype=torch.float64, requires_grad=True)
    out, da = dr.interpolate(attr, rast.detach(), tri, rast_db=db.detach(), diff_attrs='all')
    return (out ** 2).sum() + (da ** 2).sum(), attr


def texture_loss(glctx, filter_mode):
    tex = torch.rand(1, 8, 8, 2, dtype=torch.float64, requires_grad=True)
    uv = torch.rand(1, 4, 4, 2, dtype=torch.float64)
    uv_da = torch.rand(1, 4, 4, 4, dtype=torch.float64) * 0.3
    return (dr.texture(tex, uv, uv_da, filter_mode=filter_mode) ** 2).sum(), tex


def antialias_loss(glctx, op):
    pos, tri, rast, _ = scene(glctx)
    color = torch.rand(1, 12, 12, 3, dtype=torch.float64, requires_grad=True)
    return (op(color, rast, pos, tri) ** 2).sum(), color


def peeler_loss(glctx):
    pos, tri = random_mesh(2, images=1, triangles=8, requires_grad=True)
    with dr.DepthPeeler(glctx, pos, tri, (12, 12)) as peeler:
        peeler.rasterize_next_layer()
        rast, _ = peeler.rasterize_next_layer()
    return (rast ** 2).sum(), pos


LOSSES = {
    'rasterize': rasterize_loss,
    'interpolate': interpolate_loss,
    'texture nearest': lambda c: texture_loss(c, 'nearest'),
    'texture linear': lambda c: texture_loss(c, 'linear'),
    'texture linear-mipmap-linear': lambda c: texture_loss(c, 'linear-mipmap-linear'),
    'antialias': lambda c: antialias_loss(c, dr.antialias),
    'visibility_antialias': lambda c: antialias_loss(c, dr.visibility_antialias),
    'DepthPeeler': peeler_loss,
}


@pytest.mark.parametrize('op', list(LOSSES))
def test_differentiating_a_gradient_taken_with_create_graph_raises(glctx, op):
    loss, x = LOSSES[op](glctx)
    grad, = torch.autograd.grad(loss, x, create_graph=True)
    penalty = (grad ** 2).sum()
    with pytest.raises(RuntimeError, match='once_differentiable'):
        penalty.backward()


@pytest.mark.parametrize('op', list(LOSSES))
def test_a_first_gradient_with_create_graph_equals_the_plain_one(glctx, op):
    loss, x = LOSSES[op](glctx)
    plain, = torch.autograd.grad(loss, x, retain_graph=True)
    graphed, = torch.autograd.grad(loss, x, create_graph=True)
    assert torch.equal(plain, graphed.detach())
