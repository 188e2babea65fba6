"""The Python binding's overhead, and the Python examples' speed.

    PYTHONPATH=build/python /usr/bin/python3 bench/python/bench_binding.py [--reps 15] [--examples]

Workload: rasterize + interpolate (3 channels) + antialias of a 39,600-triangle
sphere at 512 x 512, float32, forward and backward. Two paths run interleaved
(one of each per repetition, medians reported) at 1 and 2 threads:
  torch   gradraster.torch's autograd Functions (checks, allocations, autograd);
  direct  the same C++ kernels through gradraster._core with preallocated
          buffers (what a C++ caller of the kernels pays).
The difference is the binding's overhead. --examples also times each
example in examples/python at 1 and 2 threads (iterations per second).
"""
import argparse
import os
import re
import statistics
import subprocess
import sys
import time

import torch

sys.path.insert(0, os.path.join(os.path.dirname(__file__), '..', '..', 'examples', 'python'))
import gradraster.torch as dr  # noqa: E402
from gradraster import _core  # noqa: E402
from common import perspective, transform, translate, uv_sphere  # noqa: E402

SIZE = 512


def workload():
    pos, _, tri = uv_sphere(rings=110, segments=180)
    clip = transform(perspective() @ translate(0, 0, -2.8), pos).contiguous()
    attr = (pos[None] * 0.5 + 0.5).contiguous()
    weight = torch.rand(1, SIZE, SIZE, 3)
    return clip, tri, attr, weight


def torch_path(glctx, clip, tri, attr, weight):
    clip = clip.detach().requires_grad_(True)
    a = attr.detach().requires_grad_(True)
    rast, _ = dr.rasterize(glctx, clip, tri, (SIZE, SIZE))
    color, _ = dr.interpolate(a, rast, tri)
    image = dr.antialias(color, rast, clip, tri)
    image.backward(weight)
    return clip.grad


class Direct:
    """The same kernel calls with buffers allocated once."""

    def __init__(self, clip, tri, attr, weight):
        self.clip, self.tri, self.attr, self.weight = clip, tri, attr, weight
        self.ctx, self.aa_ctx = _core.Context(), _core.Context()
        self.rast, self.db = torch.empty(1, SIZE, SIZE, 4), torch.empty(1, SIZE, SIZE, 4)
        self.color, self.image = torch.empty(1, SIZE, SIZE, 3), torch.empty(1, SIZE, SIZE, 3)
        self.g_color, self.g_rast = torch.empty_like(self.color), torch.empty_like(self.rast)
        self.g_attr, self.g_clip = torch.empty_like(attr), torch.empty_like(clip)
        self.topology = _core.build_topology(tri, -1, 'antialias_construct_topology_hash')

    def __call__(self, threads):
        clip, tri, attr = self.clip, self.tri, self.attr
        _core.rasterize_forward(self.ctx, clip, tri, [], self.rast, self.db, None, threads)
        _core.interpolate_forward(None, attr, self.rast, tri, None, [], self.color, None, threads)
        state = _core.antialias_forward(self.aa_ctx, clip, tri, [], self.topology, self.color, self.rast, self.image,
                                        False, threads)
        for t in (self.g_color, self.g_rast, self.g_attr, self.g_clip):
            t.zero_()
        _core.antialias_backward(self.aa_ctx, clip, tri, [], self.topology, state, self.color, self.rast, self.weight,
                                 self.g_color, self.g_clip, 1.0, threads)
        _core.interpolate_backward(None, attr, self.rast, tri, None, [], self.g_color, None, self.g_attr, self.g_rast,
                                   None, threads)
        _core.rasterize_backward(self.ctx, clip, tri, [], self.rast, self.g_rast, None, self.g_clip, threads)
        return self.g_clip


def timed(f):
    start = time.perf_counter()
    f()
    return time.perf_counter() - start


def bench_binding(reps):
    clip, tri, attr, weight = workload()
    glctx = dr.RasterizeCpuContext()
    direct = Direct(clip, tri, attr, weight)
    print(f'workload: {tri.shape[0]} triangles, {SIZE}x{SIZE}, float32, rasterize + interpolate + antialias, '
          f'forward + backward; {reps} interleaved repetitions, medians')
    for threads in (1, 2):
        torch.set_num_threads(threads)
        # Same gradients both ways (the paths run the same kernels).
        assert torch.equal(torch_path(glctx, clip, tri, attr, weight), direct(threads).clone())
        a, b = [], []
        for _ in range(reps):
            a.append(timed(lambda: torch_path(glctx, clip, tri, attr, weight)))
            b.append(timed(lambda: direct(threads)))
        ma, mb = statistics.median(a) * 1e3, statistics.median(b) * 1e3
        print(f'threads {threads}: torch {ma:7.2f} ms   direct {mb:7.2f} ms   overhead {ma - mb:6.2f} ms '
              f'({100 * (ma - mb) / mb:5.1f} %)')


def bench_batch(reps):
    """16 images of 128 x 128 (instanced mode) in one call against 16 calls, forward + backward."""
    pos, _, tri = uv_sphere(rings=60, segments=100)
    g = torch.Generator().manual_seed(5)
    angles = torch.rand(16, generator=g) * 6.28
    mvps = []
    for a in angles.tolist():
        c, s = torch.cos(torch.tensor(a)), torch.sin(torch.tensor(a))
        rot = torch.tensor([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]])
        mvps.append(perspective() @ translate(0, 0, -2.8) @ rot)
    clip = transform(torch.stack(mvps), pos).contiguous()
    attr = (pos[None] * 0.5 + 0.5).contiguous()
    weight = torch.rand(16, 128, 128, 3)
    glctx = dr.RasterizeCpuContext()

    def run(c, w):
        c = c.detach().requires_grad_(True)
        rast, _ = dr.rasterize(glctx, c, tri, (128, 128))
        color, _ = dr.interpolate(attr, rast, tri)
        dr.antialias(color, rast, c, tri).backward(w)
        return c.grad

    one_call = lambda: run(clip, weight)
    per_image = lambda: [run(clip[b:b + 1], weight[b:b + 1]) for b in range(16)]
    assert torch.equal(one_call(), torch.cat(per_image()))
    print(f'batch: 16 images of 128x128, {tri.shape[0]} triangles each, forward + backward')
    for threads in (1, 2):
        torch.set_num_threads(threads)
        a, b = [], []
        for _ in range(reps):
            a.append(timed(one_call))
            b.append(timed(per_image))
        ma, mb = statistics.median(a) * 1e3, statistics.median(b) * 1e3
        print(f'threads {threads}: one call {ma:7.2f} ms   16 calls {mb:7.2f} ms   speed-up {mb / ma:4.2f}x')


def bench_examples():
    here = os.path.join(os.path.dirname(__file__), '..', '..', 'examples', 'python')
    for name, iterations in (('cube_fit', 100), ('texture_fit', 60), ('pose_fit', 150)):
        for threads in (1, 2):
            out = subprocess.run([sys.executable, os.path.join(here, name + '.py'), '--iterations', str(iterations),
                                  '--threads', str(threads), '--out', '/tmp/gradraster-bench-examples'],
                                 capture_output=True, text=True, check=True).stdout
            rate = float(re.findall(r'([\d.]+) it/s;', out)[-1])
            print(f'{name:12s} threads {threads}: {rate:6.1f} it/s ({iterations} iterations)')


if __name__ == '__main__':
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--reps', type=int, default=15)
    p.add_argument('--examples', action='store_true', help='also time the examples at 1 and 2 threads')
    args = p.parse_args()
    bench_binding(args.reps)
    bench_batch(args.reps)
    if args.examples:
        bench_examples()
