"""Fit a cube's vertex positions and colours from a random start to images of a
reference cube seen from random views (L2 image loss, antialiased silhouettes).

    PYTHONPATH=build/python /usr/bin/python3 examples/python/cube_fit.py
"""
import torch

import gradraster.torch as dr
from common import Progress, arguments, cube, perspective, random_rotation, save_strip, transform, translate


def render(glctx, mvp, pos, col, tri, size):
    clip = transform(mvp, pos)
    rast, _ = dr.rasterize(glctx, clip, tri, (size, size))
    color, _ = dr.interpolate(col, rast, tri)
    return dr.antialias(color, rast, clip, tri)


def main():
    a = arguments(__doc__, iterations=400)
    glctx = dr.RasterizeCpuContext()
    ref_pos, tri = cube()
    ref_col = torch.rand(8, 3)
    pos = (ref_pos + 0.3 * torch.randn(8, 3)).requires_grad_(True)
    col = torch.rand(8, 3).requires_grad_(True)
    opt = torch.optim.Adam([pos, col], lr=1e-2)
    view = perspective() @ translate(0, 0, -5.0)
    fixed = view @ random_rotation(torch.Generator().manual_seed(7))
    start = render(glctx, fixed, pos.detach(), col.detach(), tri, a.size)[0]
    progress = Progress(a.iterations)
    for it in range(a.iterations):
        mvp = torch.stack([view @ random_rotation() for _ in range(4)])  # 4 views per step
        with torch.no_grad():
            target = render(glctx, mvp, ref_pos, ref_col, tri, a.size)
        loss = ((render(glctx, mvp, pos, col, tri, a.size) - target) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        progress(it, loss.item(), f'max vertex error {(pos - ref_pos).abs().max().item():.4f}')
    with torch.no_grad():
        target = render(glctx, fixed, ref_pos, ref_col, tri, a.size)[0]
        final = render(glctx, fixed, pos, col, tri, a.size)[0]
    save_strip(f'{a.out}/cube_fit.png', [target, start, final, (final - target).abs() * 4])
    print(f'{progress.rate():.1f} it/s; final max vertex error {(pos - ref_pos).abs().max().item():.4f}, '
          f'colour error {(col - ref_col).abs().max().item():.4f}')


if __name__ == '__main__':
    main()
