"""Kernel (system) time of an earth-like texture fit, with and without
gradraster's malloc tuning (docs/performance.md, "Memory").

    PYTHONPATH=build/python /usr/bin/python3 bench/python/bench_earth.py [--iterations 20] [--reps 3] [--threads N]

Workload, shaped like nvdiffrast's earth sample: a 2048 x 2048 RGB float32
texture learned with torch's Adam from 512 x 512 renders of a textured sphere;
each iteration renders the reference (no grad) and the current texture with
rasterize -> interpolate (uv derivatives) -> texture('linear-mipmap-linear',
the full mip stack rebuilt from the texture) -> L2 loss -> backward -> step.
Every iteration allocates texture-sized tensors (48 MiB gradient, 16 MiB mip
stack, Adam's temporaries): above glibc's default 32 MiB mmap ceiling, so
without tuning each one is mapped, faulted in page by page and unmapped.

Each configuration runs in its own process (the tuning is process-wide and
applied at import): `tuned` as shipped, `defaults` with
GRADRASTER_MALLOC_DEFAULTS=1 (glibc's own settings). Runs are interleaved and
the medians of user, system and wall time and of minor page faults
(resource.getrusage: every page mapped, by a trap or populated; time.perf_counter)
are printed for the whole loop and for the iterations after the first: the first one faults in the working set (Adam's state, the
gradients) whichever the settings, the later ones show what each iteration
costs once the loop runs.
"""
import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import time

CONFIGS = {'defaults': {'GRADRASTER_MALLOC_DEFAULTS': '1'}, 'tuned': {}}


def child(iterations, size, tex_side, threads):
    import torch

    if threads:
        torch.set_num_threads(threads)

    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'examples', 'python'))
    import gradraster.torch as dr
    from common import perspective, random_rotation, transform, translate, uv_sphere

    torch.manual_seed(1)
    glctx = dr.RasterizeCpuContext()
    pos, uv, tri = uv_sphere(rings=64, segments=128)
    v, u = torch.meshgrid(torch.linspace(0, 1, tex_side), torch.linspace(0, 1, tex_side), indexing='ij')
    target_tex = torch.stack([0.5 + 0.5 * torch.sin(40 * math.pi * v), ((u * 64).floor() + (v * 32).floor()) % 2,
                              1 - u], -1)[None].contiguous()
    tex = torch.full_like(target_tex, 0.5).requires_grad_(True)
    opt = torch.optim.Adam([tex], lr=1e-2)
    g = torch.Generator().manual_seed(2)

    def render(mvp, texture):
        clip = transform(mvp, pos).contiguous()
        rast, rast_db = dr.rasterize(glctx, clip, tri, (size, size))
        texc, texd = dr.interpolate(uv[None], rast, tri, rast_db, diff_attrs='all')
        return dr.texture(texture, texc, texd, filter_mode='linear-mipmap-linear')

    marks = [(resource.getrusage(resource.RUSAGE_SELF), time.perf_counter())]
    for it in range(iterations):
        mvp = perspective() @ translate(0, 0, -2.4) @ random_rotation(g)
        with torch.no_grad():
            target = render(mvp, target_tex)
        loss = ((render(mvp, tex) - target) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        if it == 0 or it == iterations - 1:
            marks.append((resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()))

    def between(a, b):
        return {'user': b[0].ru_utime - a[0].ru_utime, 'sys': b[0].ru_stime - a[0].ru_stime, 'wall': b[1] - a[1],
                'faults': b[0].ru_minflt - a[0].ru_minflt}

    print(json.dumps({'loop': between(marks[0], marks[-1]), 'first': between(marks[0], marks[1]),
                      'later': between(marks[1], marks[-1]),
                      'loss': loss.item(), 'threads': torch.get_num_threads()}))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--iterations', type=int, default=20, help='at least 2 (default %(default)s)')
    p.add_argument('--reps', type=int, default=3, help='runs of each configuration, interleaved (medians)')
    p.add_argument('--size', type=int, default=512, help='image side (default %(default)s)')
    p.add_argument('--texture', type=int, default=2048, help='texture side (default %(default)s)')
    p.add_argument('--threads', type=int, default=0, help='torch (and gradraster) threads (default: torch\'s own)')
    p.add_argument('--baseline', metavar='DIR', help='also run a `baseline` configuration with PYTHONPATH=DIR '
                   '(another build of the package, for example one before a change)')
    p.add_argument('--child', action='store_true', help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.iterations < 2:
        p.error('--iterations must be at least 2')
    if a.child:
        return child(a.iterations, a.size, a.texture, a.threads)
    configs = dict(CONFIGS, **({'baseline': {'PYTHONPATH': a.baseline}} if a.baseline else {}))
    runs = {name: [] for name in configs}
    for _ in range(a.reps):
        for name, extra in configs.items():
            env = {k: v for k, v in os.environ.items() if k != 'GRADRASTER_MALLOC_DEFAULTS'}
            out = subprocess.run([sys.executable, os.path.abspath(__file__), '--child', '--iterations',
                                  str(a.iterations), '--size', str(a.size), '--texture', str(a.texture),
                                  '--threads', str(a.threads)],
                                 env={**env, **extra}, capture_output=True, text=True, check=True).stdout
            runs[name].append(json.loads(out.splitlines()[-1]))
    print(f'{a.iterations} iterations, {a.texture}x{a.texture} texture with mip stack, {a.size}x{a.size} images, '
          f'{runs["tuned"][0]["threads"]} threads; medians of {a.reps} interleaved runs')
    for part, title in (('loop', f'all {a.iterations} iterations'), ('later', f'iterations 2..{a.iterations}')):
        print(title)
        for name, results in runs.items():
            m = {k: statistics.median(r[part][k] for r in results) for k in ('user', 'sys', 'wall', 'faults')}
            print(f'  {name:9s} user {m["user"]:6.2f} s   sys {m["sys"]:6.2f} s ({100 * m["sys"] / m["user"]:5.1f} % of '
                  f'user)   wall {m["wall"]:6.2f} s   faults {m["faults"]:8.0f}   final loss {results[-1]["loss"]:.5f}')


if __name__ == '__main__':
    main()
