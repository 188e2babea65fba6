"""Shared pieces of the Python examples: cameras, meshes, progress, images.

Every example runs with `PYTHONPATH=build/python /usr/bin/python3
examples/python/<name>.py` after scripts/setup.sh.
"""
import argparse
import math
import os
import time

import torch

import gradraster


def arguments(description, iterations, size=128):
    p = argparse.ArgumentParser(description=description)
    p.add_argument('--iterations', type=int, default=iterations, help='optimizer steps (default %(default)s)')
    p.add_argument('--size', type=int, default=size, help='image side in pixels (default %(default)s)')
    p.add_argument('--threads', type=int, default=0, help='threads (default: torch.get_num_threads())')
    p.add_argument('--out', default='out/python', help='output folder (default %(default)s)')
    p.add_argument('--seed', type=int, default=1, help='random seed (default %(default)s)')
    a = p.parse_args()
    if a.iterations < 1 or a.size < 8:
        p.error('--iterations must be >= 1 and --size >= 8')
    if a.threads > 0:
        torch.set_num_threads(a.threads)
    torch.manual_seed(a.seed)
    os.makedirs(a.out, exist_ok=True)
    return a


def perspective(fovy=math.radians(45), aspect=1.0, near=0.1, far=100.0):
    """OpenGL's projection matrix (clip y up; nvdiffrast puts clip y = -1 in image row 0)."""
    f = 1.0 / math.tan(fovy / 2)
    return torch.tensor([[f / aspect, 0, 0, 0], [0, f, 0, 0],
                         [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)], [0, 0, -1, 0]],
                        dtype=torch.float32)


def translate(x, y, z):
    m = torch.eye(4)
    m[:3, 3] = torch.tensor([x, y, z])
    return m


def quaternion_matrix(q):
    """4 x 4 rotation of a (not necessarily unit) quaternion (w, x, y, z); differentiable."""
    w, x, y, z = q / q.norm()
    r = torch.stack([
        torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)]),
        torch.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)]),
        torch.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])])
    return torch.cat([torch.cat([r, torch.zeros(3, 1)], 1), torch.tensor([[0.0, 0, 0, 1]])], 0)


def random_rotation(generator=None):
    return quaternion_matrix(torch.randn(4, generator=generator))


def transform(mtx, pos):
    """[B, 4, 4] or [4, 4] matrices applied to [N, 3] points -> [B, N, 4] clip positions."""
    homogeneous = torch.cat([pos, torch.ones_like(pos[:, :1])], 1)
    if mtx.dim() == 2:
        mtx = mtx[None]
    return torch.matmul(homogeneous[None], mtx.transpose(1, 2))


def cube():
    """8 corners of [-1, 1]^3 and 12 counter-clockwise triangles."""
    pos = torch.tensor([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
    tri = torch.tensor([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                        [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], dtype=torch.int32)
    return pos, tri


def uv_sphere(rings=24, segments=48):
    """A unit sphere with (u, v) texture coordinates; a seam column of duplicated vertices."""
    pos, uv = [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            pos.append([math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi)])
            uv.append([j / segments, i / rings])
    tri = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * (segments + 1) + j, (i + 1) * (segments + 1) + j
            tri += [[a, b, a + 1], [a + 1, b, b + 1]]
    return torch.tensor(pos), torch.tensor(uv), torch.tensor(tri, dtype=torch.int32)


class Progress:
    """Prints iteration, loss and iterations per second every `every` steps."""

    def __init__(self, total, every=None):
        self.total, self.every, self.start = total, every or max(1, total // 10), time.perf_counter()

    def __call__(self, it, loss, extra=''):
        if it % self.every == 0 or it == self.total - 1:
            rate = (it + 1) / (time.perf_counter() - self.start)
            print(f'iter {it + 1:5d}/{self.total}  loss {loss:.4e}  {rate:6.1f} it/s {extra}', flush=True)

    def rate(self):
        return self.total / (time.perf_counter() - self.start)


def save_strip(path, images):
    """Images [H, W, 3] (row 0 = clip y -1, nvdiffrast's order) side by side, top row first in the file."""
    strip = torch.cat([img.detach().clamp(0, 1).flip(0) for img in images], 1)
    gradraster.write_png(path, strip)
    print(f'wrote {path}')
