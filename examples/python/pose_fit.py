"""Recover the pose (a quaternion and a translation) of a coloured cube from one
target image, starting about 25 degrees and 0.3 units off (L2 image loss,
antialiased silhouettes).

    PYTHONPATH=build/python /usr/bin/python3 examples/python/pose_fit.py
"""
import math

import torch

import gradraster.torch as dr
from common import Progress, arguments, cube, perspective, quaternion_matrix, save_strip, transform, translate


def render(glctx, q, t, pos, col, tri, size):
    mvp = perspective() @ translate(0, 0, -6.0) @ translate_matrix(t) @ quaternion_matrix(q)
    clip = transform(mvp, pos)
    rast, _ = dr.rasterize(glctx, clip, tri, (size, size))
    color, _ = dr.interpolate(col, rast, tri)
    return dr.antialias(color, rast, clip, tri)[0]


def translate_matrix(t):
    top = torch.cat([torch.eye(3), t[:, None]], 1)
    return torch.cat([top, torch.tensor([[0.0, 0, 0, 1]])], 0)


def angle_between(q1, q2):
    """Rotation angle (degrees) between two quaternions."""
    d = (q1 / q1.norm() * q2 / q2.norm()).sum().abs().clamp(max=1.0)
    return math.degrees(2 * math.acos(d.item()))


def main():
    a = arguments(__doc__, iterations=300, size=160)
    glctx = dr.RasterizeCpuContext()
    pos, tri = cube()
    col = (pos + 1) / 2  # the RGB cube
    q_target = torch.tensor([0.9, 0.3, -0.2, 0.25])
    t_target = torch.tensor([0.2, -0.1, 0.0])
    # Start: the target rotated by 25 degrees about a random axis, translated 0.3 units.
    axis = torch.randn(3)
    axis = axis / axis.norm()
    half = math.radians(25) / 2
    dq = torch.cat([torch.tensor([math.cos(half)]), math.sin(half) * axis])
    w1, v1, w2, v2 = dq[0], dq[1:], q_target[0] / q_target.norm(), q_target[1:] / q_target.norm()
    q = torch.cat([(w1 * w2 - v1.dot(v2))[None], w1 * v2 + w2 * v1 + torch.cross(v1, v2)]).requires_grad_(True)
    t = (t_target + 0.3 * torch.nn.functional.normalize(torch.randn(3), dim=0)).requires_grad_(True)
    with torch.no_grad():
        target = render(glctx, q_target, t_target, pos, col, tri, a.size)
        start = render(glctx, q, t, pos, col, tri, a.size)
    print(f'start: {angle_between(q, q_target):.2f} degrees, {(t - t_target).norm().item():.3f} units off')
    opt = torch.optim.Adam([q, t], lr=1e-2)
    sched = torch.optim.lr_scheduler.ExponentialLR(opt, gamma=0.99)
    progress = Progress(a.iterations)
    for it in range(a.iterations):
        loss = ((render(glctx, q, t, pos, col, tri, a.size) - target) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        progress(it, loss.item(), f'angle {angle_between(q.detach(), q_target):6.3f} deg  '
                                  f'offset {(t - t_target).norm().item():.4f}')
    with torch.no_grad():
        final = render(glctx, q, t, pos, col, tri, a.size)
    save_strip(f'{a.out}/pose_fit.png', [target, start, final, (final - target).abs() * 4])
    print(f'{progress.rate():.1f} it/s; final {angle_between(q.detach(), q_target):.3f} degrees, '
          f'{(t - t_target).norm().item():.4f} units off')


if __name__ == '__main__':
    main()
