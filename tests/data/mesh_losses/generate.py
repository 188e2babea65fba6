"""Writes reference.txt: values and gradients of gradraster.losses (Python,
torch, float64) on fixed meshes, which tests/ops/mesh/test_reference.cpp
compares the C++ mesh ops against.

Run from the repository root with Debian's interpreter (torch 1.13):
    PYTHONPATH=python /usr/bin/python3 tests/data/mesh_losses/generate.py
Deterministic: the meshes come from fixed seeds, and every number is written
with 17 significant digits (exact for float64).

Meshes: 'icosphere', an icosphere of one subdivision (42 vertices, 80 faces)
with a few vertices moved; 'hard', the same with three faces removed (a hole:
boundary edges) plus an isolated vertex, a degenerate face (a, w, w) (w's only
neighbour is a), a sliver face on a boundary edge (its new vertex, of valence
2, lifted 1e-3 off the edge: near-zero area), and a fin on an interior edge (an
edge of three faces); 'zero area', 'hard' plus a face of exactly collinear
vertices (values only: at that face the Laplacians' |r| sit at a kink).
"""
import math
import os

import torch

from gradraster import losses

F64 = torch.float64


def icosphere():
    t = (1 + math.sqrt(5)) / 2
    v = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
         [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
         [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11],
         [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    v = [[c / math.sqrt(sum(x * x for x in p)) for c in p] for p in v]
    midpoint = {}

    def mid(a, b):
        key = (min(a, b), max(a, b))
        if key not in midpoint:
            p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
            n = math.sqrt(sum(x * x for x in p))
            v.append([x / n for x in p])
            midpoint[key] = len(v) - 1
        return midpoint[key]

    out = []
    for a, b, c in f:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        out += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
    return torch.tensor(v, dtype=F64), torch.tensor(out)


def perturbed_icosphere():
    v, f = icosphere()
    g = torch.Generator().manual_seed(34)
    moved = torch.tensor([0, 5, 13, 20, 27, 33, 41])
    v[moved] += 0.15 * (torch.rand((len(moved), 3), generator=g, dtype=F64) - 0.5)
    v = v * torch.tensor([1.0, 0.8, 1.2], dtype=F64)  # no symmetry to hide an index mix-up
    return v, f


def edge_faces(faces):
    count = {}
    for n, f in enumerate(faces.tolist()):
        for k in range(3):
            count.setdefault(tuple(sorted((f[k], f[(k + 1) % 3]))), []).append(n)
    return count


def hard_mesh():
    v, f = perturbed_icosphere()
    f = f[3:]  # a hole: faces 0..2 gone, their edges now on the boundary (or gone)
    count = edge_faces(f)
    boundary = sorted(e for e, fs in count.items() if len(fs) == 1)
    interior = sorted(e for e, fs in count.items() if len(fs) == 2)
    extra_v, extra_f = [], []

    def add(p):
        extra_v.append(p)
        return v.shape[0] + len(extra_v) - 1

    add([0.3, -1.7, 0.4])                           # isolated
    w = add([0.9, 0.2, 1.1])                        # (a, w, w): w's only neighbour is a
    extra_f.append([7, w, w])
    a, b = boundary[0]                              # a sliver on a boundary edge: a vertex of valence 2
    m = (0.7 * v[a] + 0.3 * v[b]).tolist()
    m[2] += 1e-3
    extra_f.append([a, b, add(m)])
    c, d = interior[len(interior) // 2]             # a fin: the edge (c, d) gets a third face
    fin = (0.5 * (v[c] + v[d]) * 1.6).tolist()
    extra_f.append([c, d, add(fin)])
    v = torch.cat([v, torch.tensor(extra_v, dtype=F64)])
    return v, torch.cat([f, torch.tensor(extra_f)]), boundary


def zero_area_mesh():
    v, f, boundary = hard_mesh()
    a, b = boundary[-1]
    m = 0.7 * v[a] + 0.3 * v[b]                      # exactly on the line: zero area (not the midpoint)
    v = torch.cat([v, m[None]])
    return v, torch.cat([f, torch.tensor([[a, b, v.shape[0] - 1]])])


def grad(fn, v):
    x = v.detach().clone().requires_grad_()
    y = fn(x)
    (g,) = torch.autograd.grad(y, x)
    return y.detach(), g


def normals_weight(v, f):
    """cos(3 i + k) for vertex i, channel k; 0 on vertices whose summed face normals are zero
    (no direction there: their normal's gradient is of order 1/eps)."""
    i = torch.arange(v.shape[0], dtype=F64)[:, None]
    k = torch.arange(3, dtype=F64)[None, :]
    w = torch.cos(3 * i + k)
    p = v[f]
    face = torch.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], dim=1)
    s = torch.zeros_like(v).index_add(0, f.reshape(-1), face.repeat_interleave(3, dim=0))
    w[torch.linalg.vector_norm(s, dim=1) < 1e-9] = 0
    return w


def entries(v, f, with_gradients):
    out = []

    def put(name, fn):
        y, g = grad(fn, v)
        out.append((name, y.reshape(-1).tolist()))
        if with_gradients:
            out.append((name + '.grad', g.reshape(-1).tolist()))

    put('mesh_edge_loss', lambda x: losses.mesh_edge_loss(x, f))
    put('mesh_edge_loss target 0.7', lambda x: losses.mesh_edge_loss(x, f, 0.7))
    for method in ('uniform', 'cot', 'cotcurv'):
        put('mesh_laplacian_smoothing ' + method, lambda x: losses.mesh_laplacian_smoothing(x, f, method))
    put('mesh_normal_consistency', lambda x: losses.mesh_normal_consistency(x, f))
    if not with_gradients:
        return out
    w = normals_weight(v, f)
    out.append(('vertex_normals weight', w.reshape(-1).tolist()))
    out.append(('vertex_normals', losses.vertex_normals(v, f).reshape(-1).tolist()))
    put('vertex_normals weighted sum', lambda x: (losses.vertex_normals(x, f) * w).sum())
    ls = losses.LargeSteps(v, f, lambda_=2.5)
    out.append(('large_steps lambda 2.5 matrix', ls.matrix.reshape(-1).tolist()))
    out.append(('large_steps lambda 2.5 to_differential', ls.to_differential(v).reshape(-1).tolist()))
    out.append(('large_steps lambda 2.5 from_differential', ls.from_differential(v).reshape(-1).tolist()))
    ls = losses.LargeSteps(v, f, alpha=0.3)
    out.append(('large_steps alpha 0.3 from_differential', ls.from_differential(v).reshape(-1).tolist()))
    return out


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    hard_v, hard_f, _ = hard_mesh()
    meshes = [('icosphere', *perturbed_icosphere(), True), ('hard', hard_v, hard_f, True),
              ('zero_area', *zero_area_mesh(), False)]
    lines = ['# Generated by tests/data/mesh_losses/generate.py (gradraster.losses, torch %s, float64); '
             'do not edit.' % torch.__version__,
             '# mesh NAME V F, then V lines "v x y z", F lines "f a b c", then lines "value NAME | N x1 .. xN",',
             '# then "end". Gradients (.grad) are with respect to the positions; the Laplacian weights are',
             '# held constant, as mesh_laplacian_smoothing does by default.']
    for name, v, f, with_gradients in meshes:
        lines.append('mesh %s %d %d' % (name, v.shape[0], f.shape[0]))
        lines += ['v %s' % ' '.join('%.17g' % x for x in p) for p in v.tolist()]
        lines += ['f %d %d %d' % tuple(t) for t in f.tolist()]
        for key, values in entries(v, f, with_gradients):
            lines.append('value %s | %d %s' % (key, len(values), ' '.join('%.17g' % x for x in values)))
        lines.append('end')
    with open(os.path.join(here, 'reference.txt'), 'w') as out:
        out.write('\n'.join(lines) + '\n')


if __name__ == '__main__':
    main()
