"""antialias: silhouette blending and its gradients to colour and positions."""
import subprocess
import sys
import textwrap

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


# A child process makes every huge-index call and measures how much its peak
# resident memory grew over each. Its address space is capped 1 GiB above what
# it holds (except under ASan, whose shadow memory needs a large address
# space), so a table sized by the index fails there with MemoryError instead of
# exhausting the machine.
HUGE_INDEX_CALLS = [(call, index) for call in ('antialias', 'visibility_antialias', 'hash')
                    for index in (10 ** 8, 2 ** 31 - 1)]
HUGE_INDEX = textwrap.dedent("""
    import os, resource, sys, torch
    import gradraster.torch as dr
    pos = torch.tensor([[[-0.5, -0.5, 0, 1], [0.5, -0.5, 0, 1], [0, 0.5, 0, 1], [0.5, 0.5, 0, 1]]], dtype=torch.float64)
    rast, _ = dr.rasterize(dr.RasterizeCpuContext(), pos, torch.tensor([[0, 1, 2]], dtype=torch.int32), (16, 16))
    color = torch.rand(1, 16, 16, 3, dtype=torch.float64)
    if 'asan' not in os.environ.get('LD_PRELOAD', ''):
        vm = int([l for l in open('/proc/self/status') if l.startswith('VmSize')][0].split()[1]) * 1024
        resource.setrlimit(resource.RLIMIT_AS, (vm + (1 << 30), resource.RLIM_INFINITY))
    for case in sys.argv[1:]:
        call, index = case.split(':')
        tri = torch.tensor([[0, 1, 2], [1, 3, int(index)]], dtype=torch.int32)
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        try:
            if call == 'hash':
                dr.antialias_construct_topology_hash(tri)
                outcome = 'built'
            else:
                getattr(dr, call)(color, rast, pos, tri)
                outcome = 'no error'
        except Exception as e:
            outcome = f'{type(e).__name__}: {e}'
        grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) // 1024
        print(f'{case}|{grown}|{outcome}')
""")


@pytest.fixture(scope='module')
def huge_index_outcomes():
    """(call, index) -> (MiB the peak resident memory grew by, outcome)."""
    run = subprocess.run([sys.executable, '-c', HUGE_INDEX] + [f'{c}:{i}' for c, i in HUGE_INDEX_CALLS],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    outcomes = {}
    for line in run.stdout.splitlines():
        case, grown, outcome = line.split('|')
        call, index = case.split(':')
        outcomes[call, int(index)] = int(grown), outcome
    return outcomes


@pytest.mark.parametrize('index', [10 ** 8, 2 ** 31 - 1])
@pytest.mark.parametrize('call', ['antialias', 'visibility_antialias'])
def test_one_huge_triangle_index_is_an_index_error_before_any_table_is_sized_by_it(huge_index_outcomes, call, index):
    grown, outcome = huge_index_outcomes[call, index]
    assert outcome == f"IndexError: {call}: tris[1][2] = {index} is outside [0, 4)"
    assert grown < 32


@pytest.mark.parametrize('index', [10 ** 8, 2 ** 31 - 1])
def test_a_topology_hash_with_a_huge_index_takes_memory_by_triangles_not_by_the_index(huge_index_outcomes, index):
    grown, outcome = huge_index_outcomes['hash', index]
    assert outcome == 'built' and grown < 32


def test_a_topology_hash_with_sparse_indices_pairs_the_same_edges():
    # The same mesh with its vertices renumbered far apart (in the same order)
    # gives the same antialiased image through a prebuilt hash.
    glctx = dr.RasterizeCpuContext()
    pos, tri = two_triangles()
    rast, _ = dr.rasterize(glctx, pos, tri, (16, 16))
    color = torch.rand(1, 16, 16, 3, dtype=torch.float64)
    sparse = tri.long() * 10_000_000 + 7
    assert sparse.max() < 2 ** 31
    dense_hash = dr.antialias_construct_topology_hash(tri)
    sparse_hash = dr.antialias_construct_topology_hash(sparse.int())
    assert torch.equal(dr.antialias(color, rast, pos, tri, topology_hash=dense_hash),
                       dr.antialias(color, rast, pos, tri, topology_hash=sparse_hash))


@pytest.mark.parametrize('op', [dr.antialias, dr.visibility_antialias])
def test_antialias_runs_under_torch_inference_mode_with_the_no_grad_result(glctx, op):
    # Tensors made under torch.inference_mode() keep no version counter (reading tri._version raises); the
    # topology antialias keeps for tri must still be found again, and built anew once tri is written.
    pos, tri = two_triangles(dtype=torch.float32)
    other = torch.tensor([[0, 1, 3], [0, 3, 2]], dtype=torch.int32)  # the quad's other diagonal
    color = torch.rand(1, 16, 14, 3, generator=torch.Generator().manual_seed(1))
    want = {}
    with torch.no_grad():
        for name, t in (('tri', tri), ('other', other)):
            rast, _ = dr.rasterize(glctx, pos, t, (16, 14))
            want[name] = (rast, op(color, rast, pos, t))
    stale = op(color, want['other'][0], pos, other, topology_hash=dr.antialias_construct_topology_hash(tri))
    assert not torch.equal(stale, want['other'][1])  # the test sees a topology kept for tri's old values
    with torch.inference_mode():
        pos_i, tri_i, color_i = pos.clone(), tri.clone(), color.clone()
        assert tri_i.is_inference()
        got = [op(color_i, want['tri'][0], pos_i, tri_i) for _ in range(2)]
        tri_i.copy_(other)
        written = op(color_i, want['other'][0], pos_i, tri_i)
    assert all(torch.equal(g, want['tri'][1]) for g in got)
    assert torch.equal(written, want['other'][1])
