"""DepthPeeler: successive layers, each an ordinary differentiable G-buffer."""
import pytest
import torch
from torch.autograd import gradcheck

import gradraster.torch as dr
from conftest import random_mesh


def quad(z, w=1.0):
    return [[-0.8 * w, -0.8 * w, z * w, w], [0.8 * w, -0.8 * w, z * w, w], [0.8 * w, 0.8 * w, z * w, w],
            [-0.8 * w, 0.8 * w, z * w, w]]


def stacked_quads():
    # Three full-screen-ish quads at z = 0.5, -0.2 (nearest) and a coplanar duplicate of the first.
    pos = torch.tensor([quad(0.5) + quad(-0.2) + quad(0.5)], dtype=torch.float64)
    tri = torch.tensor([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7], [8, 9, 10], [8, 10, 11]], dtype=torch.int32)
    return pos, tri


def test_layers_come_front_to_back_and_coplanar_duplicates_each_appear_once(glctx):
    pos, tri = stacked_quads()
    layers = []
    with dr.DepthPeeler(glctx, pos, tri, (8, 8)) as peeler:
        for _ in range(5):
            layers.append(peeler.rasterize_next_layer()[0])
    centre = [int(layer[0, 4, 4, 3]) for layer in layers]
    assert centre[0] in (3, 4)                      # the nearest quad (z = -0.2)
    assert sorted(centre[1:3]) in ([1, 5], [2, 6])  # then the two coplanar quads, each once
    assert centre[3:] == [0, 0]                     # then nothing
    assert torch.count_nonzero(layers[3]) == 0 and torch.count_nonzero(layers[4]) == 0


def test_the_first_layer_equals_rasterize(glctx):
    pos, tri = random_mesh(7, triangles=8)
    rast, db = dr.rasterize(glctx, pos, tri, (16, 12))
    with dr.DepthPeeler(glctx, pos, tri, (16, 12)) as peeler:
        r1, d1 = peeler.rasterize_next_layer()
    assert torch.equal(rast, r1) and torch.equal(db, d1)


def test_every_covered_pixel_of_each_layer_lies_behind_the_previous_one(glctx):
    pos, tri = random_mesh(8, triangles=10)
    with dr.DepthPeeler(glctx, pos, tri, (16, 12)) as peeler:
        prev = peeler.rasterize_next_layer()[0]
        for _ in range(4):
            cur = peeler.rasterize_next_layer()[0]
            both = (prev[0, ..., 3] > 0) & (cur[0, ..., 3] > 0)
            assert (cur[0, ..., 2][both] >= prev[0, ..., 2][both]).all()
            assert ((cur[0, ..., 3] > 0) <= (prev[0, ..., 3] > 0)).all()  # no pixel reappears
            prev = cur


def test_second_layer_gradients_match_finite_differences(glctx):
    pos, tri = random_mesh(9, triangles=8, requires_grad=True)
    w = torch.randn(1, 16, 12, 3, dtype=torch.float64)

    def f(p):
        with dr.DepthPeeler(glctx, p, tri, (16, 12)) as peeler:
            peeler.rasterize_next_layer()
            rast, _ = peeler.rasterize_next_layer()
        return (rast[..., :3] * w).sum()
    assert gradcheck(f, (pos,), eps=1e-6, atol=1e-8)


def test_rasterize_next_layer_outside_a_with_block_and_rasterize_inside_one_are_errors(glctx):
    pos, tri = random_mesh(1)
    peeler = dr.DepthPeeler(glctx, pos, tri, (8, 8))
    with pytest.raises(RuntimeError, match='inside'):
        peeler.rasterize_next_layer()
    with peeler:
        with pytest.raises(RuntimeError, match='depth peeling'):
            dr.rasterize(glctx, pos, tri, (8, 8))
    with pytest.raises(RuntimeError, match='re-enter'):
        with peeler:
            pass


def test_resizing_pos_between_layers_is_refused_not_a_heap_corruption(glctx):
    pos, tri = random_mesh(3, images=1, triangles=20)
    with dr.DepthPeeler(glctx, pos, tri, (16, 16)) as peeler:
        peeler.rasterize_next_layer()
        pos.resize_(4, 60, 4)  # a bigger minibatch: the peeler's per-pixel state is for one image
        with pytest.raises(RuntimeError, match="DepthPeeler: 'pos' was changed in place"):
            peeler.rasterize_next_layer()


@pytest.mark.parametrize('change', ['write pos', 'resize tri', 'write ranges'])
def test_inputs_changed_in_place_between_layers_are_refused_naming_them(glctx, change):
    pos, tri = random_mesh(4, images=1, triangles=8)
    pos, ranges = pos[0].clone(), torch.tensor([[0, 8], [2, 4]], dtype=torch.int32)
    name = change.split()[1]
    with dr.DepthPeeler(glctx, pos, tri, (8, 8), ranges=ranges) as peeler:
        peeler.rasterize_next_layer()
        if change == 'write pos':
            pos[0, 0] += 0.1
        elif change == 'resize tri':
            tri.resize_(4, 3)
        else:
            ranges[1, 1] = 6
        with pytest.raises(RuntimeError, match=f"DepthPeeler: '{name}' was changed in place"):
            peeler.rasterize_next_layer()


def test_the_peel_state_refuses_a_layer_of_another_size_even_past_the_python_check(glctx):
    # The C++ state is sized by the first layer; a later one of another size is
    # refused there too (here the Python check is told the resize is fine).
    pos, tri = random_mesh(3, images=1, triangles=20)
    with dr.DepthPeeler(glctx, pos, tri, (16, 16)) as peeler:
        peeler.rasterize_next_layer()
        pos.resize_(4, 60, 4)
        pos.copy_(random_mesh(3, images=4, triangles=20)[0])
        peeler.inputs['pos'] = dr.ops._identity(pos)
        with pytest.raises(ValueError, match="DepthPeeler: layer 2 has 4 images of 16 x 16 pixels, but the layers "
                                             "before it had 256 pixels in all"):
            peeler.rasterize_next_layer()


def test_depth_peeling_runs_under_torch_inference_mode_and_still_refuses_pos_written_between_layers(glctx):
    # Inference tensors keep no version counter: the peeler must see writes to them another way.
    pos, tri = random_mesh(4, images=1, triangles=8)
    with dr.DepthPeeler(glctx, pos, tri, (8, 8)) as peeler:
        want = [peeler.rasterize_next_layer()[0] for _ in range(2)]
    with torch.inference_mode():
        pos_i, tri_i = pos.clone(), tri.clone()
        with dr.DepthPeeler(glctx, pos_i, tri_i, (8, 8)) as peeler:
            got = [peeler.rasterize_next_layer()[0] for _ in range(2)]
        assert all(torch.equal(g, w) for g, w in zip(got, want))
        with dr.DepthPeeler(glctx, pos_i, tri_i, (8, 8)) as peeler:
            peeler.rasterize_next_layer()
            pos_i[0, 0] += 0.1
            with pytest.raises(RuntimeError, match="DepthPeeler: 'pos' was changed in place"):
                peeler.rasterize_next_layer()
