"""Recover a sphere's normal map and roughness texture from shaded views: GGX
(glTF metallic-roughness) with tangent-space normal mapping, three directional
lights and an SH sky (gradraster.shading), rendered with gradraster.torch; L2
loss on sRGB images from random views.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/ggx_fit.py
"""
import math

import torch
import torch.nn.functional as F

import gradraster.torch as dr
from gradraster import shading
from common import Progress, arguments, perspective, random_rotation, save_strip, transform, translate, uv_sphere

BASE_COLOR = torch.tensor([0.75, 0.45, 0.25])
METALLIC = torch.tensor([0.3])
LIGHTS = F.normalize(torch.tensor([[0.6, 0.7, 0.9], [-0.8, 0.1, 0.6], [0.1, -0.9, 0.5]]), dim=1)  # view space
RADIANCE = torch.tensor([[2.5, 2.4, 2.2], [1.2, 1.3, 1.5], [1.0, 1.0, 1.0]])
SKY = shading.sh_directional_light(torch.tensor([0.0, 1.0, 0.3]), torch.tensor([0.5, 0.55, 0.6]))


def reference_maps(h=32, w=64):
    """Bumps (a tangent-space normal map from a height field) and roughness stripes."""
    v, u = torch.meshgrid((torch.arange(h) + 0.5) / h, (torch.arange(w) + 0.5) / w, indexing='ij')
    # the tangent-space normal (-df/du, -df/dv, 1) of bumps f = 0.02 sin(16 pi u) sin(8 pi v): slopes up to 45 deg
    dfu = 0.02 * 16 * math.pi * torch.cos(2 * math.pi * 8 * u) * torch.sin(2 * math.pi * 4 * v)
    dfv = 0.02 * 8 * math.pi * torch.sin(2 * math.pi * 8 * u) * torch.cos(2 * math.pi * 4 * v)
    m = F.normalize(torch.stack([-dfu, -dfv, torch.ones_like(u)], -1), dim=-1)
    roughness = 0.25 + 0.45 * (torch.sin(2 * math.pi * 3 * v) > 0).float()
    return (0.5 * m + 0.5)[None], roughness[None, :, :, None]


def to_object(rotation, x):
    """View-space vectors x [3] in the object space of each rotation [B, 4, 4] -> [B, 3]."""
    return rotation[:, :3, :3].transpose(1, 2) @ x


def render(glctx, rotation, pos, attrs, tri, normal_map, roughness_map, size):
    """Views of the object turned by `rotation` [B, 4, 4], shaded in object space."""
    eye = to_object(rotation, torch.tensor([0.0, 0.0, 3.2]))  # the camera, 3.2 in front of the object
    clip = transform(perspective() @ translate(0, 0, -3.2) @ rotation, pos)
    rast, _ = dr.rasterize(glctx, clip, tri, (size, size))
    a, _ = dr.interpolate(attrs, rast, tri)
    p, n, tangent, uv = a[..., 0:3], F.normalize(a[..., 3:6], dim=-1), a[..., 6:10], a[..., 10:12].contiguous()
    n = shading.perturb_normal(n, tangent, dr.texture(normal_map, uv, filter_mode='linear'))
    roughness = dr.texture(roughness_map, uv, filter_mode='linear')
    v = F.normalize(eye[:, None, None, :] - p, dim=-1)
    color = shading.sh_diffuse(BASE_COLOR * (1 - METALLIC), n, SKY)
    for direction, radiance in zip(LIGHTS, RADIANCE):
        l, radiance = shading.directional_light(to_object(rotation, direction)[:, None, None, :], radiance)
        color = color + shading.cook_torrance(BASE_COLOR, METALLIC, roughness, n, l, v) * radiance
    color = shading.linear_to_srgb(color.clamp(min=0)) * (rast[..., 3:] > 0)
    return dr.antialias(color, rast, clip, tri)


def errors(normal_map, roughness_map, target_normals, target_roughness):
    """Mean angle (degrees) between decoded normal-map texels, and mean roughness error."""
    dots = (F.normalize(2 * normal_map - 1, dim=-1) * F.normalize(2 * target_normals - 1, dim=-1)).sum(-1)
    angle = torch.rad2deg(torch.acos(dots.clamp(-1, 1))).mean().item()
    return angle, (roughness_map - target_roughness).abs().mean().item()


def main():
    a = arguments(__doc__, iterations=200, size=64)
    glctx = dr.RasterizeCpuContext()
    pos, uv, tri = uv_sphere()
    tangents = shading.vertex_tangents(pos, uv, tri, pos)  # the unit sphere's normals are its positions
    attrs = torch.cat([pos, pos, tangents, uv], -1)  # [N, 12]: position, normal, tangent (t, w), uv
    target_normals, target_roughness = reference_maps()
    normal_map = torch.full_like(target_normals, 0.5)
    normal_map[..., 2] = 1.0  # flat: (0, 0, 1) in tangent space
    normal_map.requires_grad_(True)
    roughness_map = torch.full_like(target_roughness, 0.5).requires_grad_(True)
    opt = torch.optim.Adam([normal_map, roughness_map], lr=3e-2)
    schedule = torch.optim.lr_scheduler.LambdaLR(opt, lambda it: 0.05 ** (it / a.iterations))  # 3e-2 -> 1.5e-3
    fixed = random_rotation(torch.Generator().manual_seed(3))[None]
    angle, rough = errors(normal_map.detach(), roughness_map.detach(), target_normals, target_roughness)
    print(f'start: normal error {angle:.2f} deg, roughness error {rough:.3f}')
    progress, recent = Progress(a.iterations), []
    for it in range(a.iterations):
        rotation = torch.stack([random_rotation() for _ in range(3)])
        with torch.no_grad():
            target = render(glctx, rotation, pos, attrs, tri, target_normals, target_roughness, a.size)
        loss = ((render(glctx, rotation, pos, attrs, tri, normal_map, roughness_map, a.size) - target) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        schedule.step()
        recent = (recent + [loss.item()])[-20:]  # the loss of random views is noisy: show a running mean too
        progress(it, loss.item(), f' mean of the last {len(recent)}: {sum(recent) / len(recent):.4e}')
    angle, rough = errors(normal_map.detach(), roughness_map.detach(), target_normals, target_roughness)
    print(f'{progress.rate():.1f} it/s; normal error {angle:.2f} deg, roughness error {rough:.3f}')
    with torch.no_grad():
        target = render(glctx, fixed, pos, attrs, tri, target_normals, target_roughness, a.size)[0]
        final = render(glctx, fixed, pos, attrs, tri, normal_map, roughness_map, a.size)[0]
    save_strip(f'{a.out}/ggx_fit.png', [target, final, (final - target).abs() * 4])
    maps = [target_normals[0], normal_map[0], target_roughness[0].expand(-1, -1, 3), roughness_map[0].expand(-1, -1, 3)]
    save_strip(f'{a.out}/ggx_fit_maps.png', [m.flip(0) for m in maps])


if __name__ == '__main__':
    main()
