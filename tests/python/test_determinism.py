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


def test_a_torch_thread_count_above_the_kernels_limit_runs_on_all_hardware_threads_with_the_same_bits(
        glctx, monkeypatch):
    # torch.set_num_threads takes any count (2000 here), the kernels at most
    # 1024: a larger count means all hardware threads. torch's count is
    # patched, not set: torch.set_num_threads(2000) alone takes torch about a
    # minute on a two-core machine.
    pos, tri = random_mesh(21, images=2, triangles=200, requires_grad=True)
    upstream = torch.rand(2, 32, 32, 4, dtype=pos.dtype)

    def run():
        rast, db = dr.rasterize(glctx, pos, tri, (32, 32))
        return [rast, db] + list(torch.autograd.grad(rast, pos, upstream))

    want = run()
    monkeypatch.setattr(torch, 'get_num_threads', lambda: 2000)
    got = run()
    for a, b in zip(want, got):
        assert torch.equal(a, b)
