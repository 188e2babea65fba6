"""Learn a sphere's texture from views of a reference: mipmapped lookups with
uv derivatives from interpolate's diff_attrs, random views, L2 image loss.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/texture_fit.py
"""
import math

import torch

import gradraster.torch as dr
from common import Progress, arguments, perspective, random_rotation, save_strip, transform, translate, uv_sphere


def reference_texture(h=128, w=256):
    """Stripes and a checker, so that every mip level has something to learn."""
    v, u = torch.meshgrid(torch.linspace(0, 1, h), torch.linspace(0, 1, w), indexing='ij')
    stripes = 0.5 + 0.5 * torch.sin(2 * math.pi * 6 * v)
    checker = ((u * 16).floor() + (v * 8).floor()) % 2
    return torch.stack([stripes, 0.3 + 0.5 * checker, 1 - 0.7 * u], -1)[None]


def render(glctx, mvp, pos, uv, tri, tex, size):
    clip = transform(mvp, pos)
    rast, rast_db = dr.rasterize(glctx, clip, tri, (size, size))
    texc, texd = dr.interpolate(uv, rast, tri, rast_db, diff_attrs='all')
    color = dr.texture(tex, texc, texd, filter_mode='linear-mipmap-linear', max_mip_level=4)
    color = color * (rast[..., 3:] > 0)
    return dr.antialias(color, rast, clip, tri)


def main():
    a = arguments(__doc__, iterations=300)
    glctx = dr.RasterizeCpuContext()
    pos, uv, tri = uv_sphere()
    target_tex = reference_texture()
    tex = torch.full_like(target_tex, 0.5).requires_grad_(True)
    opt = torch.optim.Adam([tex], lr=3e-2)
    view = perspective() @ translate(0, 0, -3.2)
    fixed = view @ random_rotation(torch.Generator().manual_seed(3))
    progress = Progress(a.iterations)
    for it in range(a.iterations):
        mvp = torch.stack([view @ random_rotation() for _ in range(4)])
        # Views from farther away too, so that coarse mip levels are used.
        mvp[2:] = perspective() @ translate(0, 0, -8.0) @ torch.stack([random_rotation() for _ in range(2)])
        with torch.no_grad():
            target = render(glctx, mvp, pos, uv, tri, target_tex, a.size)
        loss = ((render(glctx, mvp, pos, uv, tri, tex, a.size) - target) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        progress(it, loss.item())
    with torch.no_grad():
        target = render(glctx, fixed, pos, uv, tri, target_tex, a.size)[0]
        final = render(glctx, fixed, pos, uv, tri, tex, a.size)[0]
    save_strip(f'{a.out}/texture_fit.png', [target, final, (final - target).abs() * 4])
    save_strip(f'{a.out}/texture_fit_texture.png', [target_tex[0].flip(0), tex[0].flip(0)])
    print(f'{progress.rate():.1f} it/s; texture error (mean abs, texels seen) '
          f'{(tex - target_tex).abs().mean().item():.4f}')


if __name__ == '__main__':
    main()
