"""rasterize: nvdiffrast's conventions by hand, and gradients against finite differences."""
import pytest
import torch
from torch.autograd import gradcheck

import gradraster.torch as dr
from conftest import near_plane_mesh, random_mesh, two_triangles


def one_triangle():
    # Vertices 0 and 1 along the bottom (clip y = -0.5), vertex 2 at the top.
    pos = torch.tensor([[[-0.5, -0.5, 0.0, 1.0], [0.5, -0.5, 0.0, 1.0], [0.0, 0.5, 0.5, 1.0]]], dtype=torch.float64)
    return pos, torch.tensor([[0, 1, 2]], dtype=torch.int32)


def test_one_triangle_covers_exactly_the_pixels_whose_centres_lie_inside_with_row_zero_at_the_bottom(glctx):
    pos, tri = one_triangle()
    rast, _ = dr.rasterize(glctx, pos, tri, (8, 8))
    # Pixel (row, col) has its centre at clip (-1 + (col + 0.5) / 4, -1 + (row + 0.5) / 4).
    expected = torch.zeros(8, 8)
    for row in range(8):
        y = -1 + (row + 0.5) / 4
        for col in range(8):
            x = -1 + (col + 0.5) / 4
            inside = y > -0.5 and y < 0.5 and abs(x) < 0.5 * (0.5 - y)
            expected[row, col] = 1.0 if inside else 0.0
    assert torch.equal(rast[0, :, :, 3], expected.double())
    # The wide base is at the bottom: rows 2 and 3 (y = -0.375, -0.125) have 4 and 2 pixels.
    assert rast[0, 2, :, 3].sum() == 4 and rast[0, 5, :, 3].sum() == 0


def test_u_v_are_the_barycentrics_of_vertices_0_and_1_and_z_over_w_is_interpolated(glctx):
    pos, tri = one_triangle()
    rast, _ = dr.rasterize(glctx, pos, tri, (8, 8))
    # Row 2, column 4: clip (0.125, -0.375): b2 = y + 0.5 = 0.125, b1 - b0 = 2x = 0.25.
    u, v, zw, ident = rast[0, 2, 4].tolist()
    assert u == pytest.approx(0.3125, abs=1e-15)
    assert v == pytest.approx(0.5625, abs=1e-15)
    assert zw == pytest.approx(0.5 * 0.125, abs=1e-15)  # z = 0, 0, 0.5 at the vertices, w = 1
    assert ident == 1.0


def test_rast_db_holds_the_pixel_derivatives_of_u_and_v(glctx):
    pos, tri = one_triangle()
    _, db = dr.rasterize(glctx, pos, tri, (8, 8))
    # One pixel is 0.25 in clip x and y; b0 = 0.5 - x - y/2 ... : du/dx = -1, du/dy = -1/2, dv/dx = 1, dv/dy = -1/2.
    assert db[0, 2, 4].tolist() == pytest.approx([-0.25, -0.125, 0.25, -0.125], abs=1e-15)
    assert torch.count_nonzero(db[0, 0]) == 0  # background


def test_background_pixels_are_all_zero(glctx):
    pos, tri = one_triangle()
    rast, db = dr.rasterize(glctx, pos, tri, (8, 8))
    background = rast[0, :, :, 3] == 0
    assert torch.count_nonzero(rast[0][background]) == 0
    assert torch.count_nonzero(db[0][background]) == 0


def test_perspective_barycentrics_reproduce_a_vertex_attribute_exactly(glctx):
    # Interpolating clip x, y, w with (u, v) and dividing gives the pixel centre back.
    pos, tri = two_triangles()
    rast, _ = dr.rasterize(glctx, pos, tri, (12, 10))
    out, _ = dr.interpolate(pos[0], rast, tri)
    covered = rast[0, :, :, 3] > 0
    rows, cols = torch.nonzero(covered, as_tuple=True)
    x = out[0, rows, cols, 0] / out[0, rows, cols, 3]
    y = out[0, rows, cols, 1] / out[0, rows, cols, 3]
    assert torch.allclose(x, -1 + (cols.double() + 0.5) * 2 / 10, atol=1e-13)
    assert torch.allclose(y, -1 + (rows.double() + 0.5) * 2 / 12, atol=1e-13)


def test_float32_and_float64_agree(glctx):
    pos, tri = two_triangles()
    r64, d64 = dr.rasterize(glctx, pos, tri, (12, 10))
    r32, d32 = dr.rasterize(glctx, pos.float(), tri, (12, 10))
    assert r32.dtype == torch.float32
    assert torch.equal(r32[..., 3].double(), r64[..., 3])
    assert torch.allclose(r32.double(), r64, atol=1e-6) and torch.allclose(d32.double(), d64, atol=1e-6)


@pytest.mark.parametrize('scene', ['two_triangles', 'random', 'near_plane'])
def test_gradients_of_rast_and_rast_db_match_finite_differences(glctx, scene):
    pos, tri = {'two_triangles': two_triangles, 'random': lambda **k: random_mesh(3, **k),
                'near_plane': near_plane_mesh}[scene](requires_grad=True)
    # Fixed coverage: finite differences must not move a pixel centre across an edge, so the
    # check is on smooth functions of the outputs weighted by fixed random images.
    g = torch.Generator().manual_seed(1)
    wr = torch.randn(1, 12, 10, 3, generator=g, dtype=torch.float64)
    wd = torch.randn(1, 12, 10, 4, generator=g, dtype=torch.float64)

    def f(p):
        rast, db = dr.rasterize(glctx, p, tri, (12, 10))
        return (rast[..., :3] * wr).sum(), (db * wd).sum()
    assert gradcheck(f, (pos,), eps=1e-6, atol=1e-8, rtol=1e-6)


def test_grad_db_false_stops_the_gradient_of_rast_db(glctx):
    pos, tri = two_triangles(requires_grad=True)
    _, db = dr.rasterize(glctx, pos, tri, (12, 10), grad_db=False)
    db.sum().backward()
    assert torch.count_nonzero(pos.grad) == 0


@pytest.mark.parametrize('pos, dtype', [
    # A held-out probe's triangles: the near clip's crossing rounds to w = 0, and the clip at w >= eps then
    # returned 6 vertices into a buffer of 5 (a crash).
    ([[0.0, 0.0, 1.0, 8.450317805236423e-30], [0.0, 0.0, -6e21, 3.145296033664205e16],
      [-1.4666088645753916e-06, 0.13414649665355682, 0.0, 1.0]], torch.float32),
    ([[-0.4, 0.1, -1e300, 1.0], [1.0, 0.1, 0.5, 1e-300], [1.0, 0.1, 0.5, 0.0]], torch.float64),
])
def test_a_near_clip_crossing_that_rounds_to_w_zero_gives_a_valid_gbuffer(glctx, pos, dtype):
    rast, db = dr.rasterize(glctx, torch.tensor([pos], dtype=dtype), torch.tensor([[0, 1, 2]], dtype=torch.int32),
                            (16, 16))
    assert set(rast[..., 3].flatten().tolist()) <= {0.0, 1.0}
    assert torch.isfinite(rast).all() and torch.isfinite(db).all()
