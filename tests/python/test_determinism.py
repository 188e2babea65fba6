"""Bit-identical images and gradients for 1, 2 and 8 threads (torch.get_num_threads())."""
import pytest
import torch

import gradraster.torch as dr
from conftest import random_mesh


def pipeline(glctx, dtype):
    pos, tri = random_mesh(21, images=2, triangles=200, dtype=dtype, requires_grad=True)
    attr = torch.linspace(-1, 1, pos.shape[1] * 3, dtype=dtype).reshape(1, -1, 3).requires_grad_(True)
    rast, db = dr.rasterize(glctx, pos, tri, (96, 80))
    out, da = dr.interpolate(attr, rast, tri, db, diff_attrs='all')
    img = dr.antialias(torch.cat([out, da], -1), rast, pos, tri)
    vis = dr.visibility_antialias(out, rast, pos, tri)  # 200 random triangles interpenetrate
    loss = (img * img).sum() + (vis * vis).sum()
    return [rast, db, img, vis] + list(torch.autograd.grad(loss, (pos, attr)))


@pytest.mark.parametrize('dtype', [torch.float32, torch.float64])
def test_outputs_and_gradients_are_bit_identical_for_1_2_and_8_threads(glctx, dtype):
    saved = torch.get_num_threads()
    try:
        runs = []
        for threads in (1, 2, 8, 1):
            torch.set_num_threads(threads)
            runs.append(pipeline(glctx, dtype))
    finally:
        torch.set_num_threads(saved)
    for run in runs[1:]:
        for a, b in zip(runs[0], run):
            assert torch.equal(a, b)
