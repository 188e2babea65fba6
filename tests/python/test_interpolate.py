"""interpolate: the linear blend with rast's barycentrics, its derivatives, and gradients."""
import pytest
import torch
from torch.autograd import gradcheck

import gradraster.torch as dr
from conftest import near_plane_mesh, random_mesh, two_triangles


def test_attributes_are_blended_as_u_a0_plus_v_a1_plus_one_minus_u_minus_v_a2(glctx):
    pos, tri = two_triangles()
    rast, _ = dr.rasterize(glctx, pos, tri, (12, 10))
    attr = torch.randn(4, 3, dtype=torch.float64)
    out, da = dr.interpolate(attr, rast, tri)
    u, v, ident = rast[0, ..., 0], rast[0, ..., 1], rast[0, ..., 3].long()
    t = tri.long()[(ident - 1).clamp(min=0)]
    expected = u[..., None] * attr[t[..., 0]] + v[..., None] * attr[t[..., 1]] + (1 - u - v)[..., None] * attr[t[..., 2]]
    expected[ident == 0] = 0
    assert torch.allclose(out[0], expected, atol=1e-15)
    assert da.shape == (1, 12, 10, 0)


def test_attribute_derivatives_match_neighbouring_pixel_differences_of_a_linear_attribute(glctx):
    # For attr = clip position, A / w is affine in the pixel: check d(A)/dX through the quotient rule.
    pos, tri = two_triangles()
    rast, db = dr.rasterize(glctx, pos, tri, (12, 10))
    out, da = dr.interpolate(pos[0], rast, tri, db, diff_attrs=[0, 3])
    x, w = out[0, ..., 0], out[0, ..., 3]
    dx_dX, dw_dX = da[0, ..., 0], da[0, ..., 2]
    covered = rast[0, ..., 3] > 0
    # x / w = -1 + (col + 0.5) / 5, so d(x / w)/dX = (dx w - x dw) / w^2 = 1 / 5 per pixel.
    ratio = (dx_dX * w - x * dw_dX) / (w * w)
    assert torch.allclose(ratio[covered], torch.full_like(ratio[covered], 0.2), atol=1e-12)


def test_diff_attrs_all_orders_channels_as_dA_dX_dA_dY_per_attribute(glctx):
    pos, tri = two_triangles()
    rast, db = dr.rasterize(glctx, pos, tri, (12, 10))
    attr = torch.randn(4, 3, dtype=torch.float64)
    _, all_ = dr.interpolate(attr, rast, tri, db, diff_attrs='all')
    _, one = dr.interpolate(attr, rast, tri, db, diff_attrs=[2])
    assert all_.shape == (1, 12, 10, 6) and torch.equal(all_[..., 4:6], one)


@pytest.mark.parametrize('scene', ['two_triangles', 'random', 'near_plane'])
def test_gradients_to_attr_rast_and_rast_db_match_finite_differences(glctx, scene):
    pos, tri = {'two_triangles': two_triangles, 'random': lambda **k: random_mesh(5, **k),
                'near_plane': near_plane_mesh}[scene]()
    rast, db = dr.rasterize(glctx, pos, tri, (12, 10))
    attr = torch.randn(1, pos.shape[1], 3, dtype=torch.float64, requires_grad=True)
    # u, v are differentiable inputs; z/w and the id stay fixed.
    uv = rast[..., :2].clone().requires_grad_(True)
    db = db.clone().requires_grad_(True)

    def f(a, uv, d):
        return dr.interpolate(a, torch.cat([uv, rast[..., 2:]], -1), tri, d, diff_attrs=[0, 2])
    assert gradcheck(f, (attr, uv, db), eps=1e-6, atol=1e-8)


def test_gradients_flow_from_attribute_derivatives_back_to_positions(glctx):
    pos, tri = two_triangles(requires_grad=True)
    attr = torch.randn(4, 2, dtype=torch.float64, requires_grad=True)
    w = torch.randn(1, 12, 10, 6, dtype=torch.float64)

    def f(p, a):
        rast, db = dr.rasterize(glctx, p, tri, (12, 10))
        out, da = dr.interpolate(a, rast, tri, db, diff_attrs='all')
        return (torch.cat([out, da], -1) * w).sum()
    assert gradcheck(f, (pos, attr), eps=1e-6, atol=1e-8)
