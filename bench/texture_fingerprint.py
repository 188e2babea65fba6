"""What KeptTextures' fingerprint costs against the upload it saves (docs/gpu.md, "What stays resident").

For a 2048 x 2048 x 3 float32 texture: the wall time of _core.fingerprint on 1 and 2 threads (best and median of
interleaved runs), and, on a RasterizeVulkanContext, the texture_residency bytes and the wall time of a bilinear
texture call that uploads the texture (another tensor each time) against one that reads the kept copy (the same
tensor: fingerprint included; and with a constant fingerprint, the check before fingerprints).
Run: PYTHONPATH=build/python /usr/bin/python3 bench/texture_fingerprint.py
"""
import statistics
import time

import torch

import gradraster.torch as dr
from gradraster import _core

SIDE, CHANNELS, RUNS = 2048, 3, 15


def timed(f):
    start = time.perf_counter()
    f()
    return time.perf_counter() - start


def report(name, seconds):
    print(f"{name}: best {min(seconds) * 1e3:.2f} ms, median {statistics.median(seconds) * 1e3:.2f} ms")


def main():
    tex = torch.rand(1, SIDE, SIDE, CHANNELS, generator=torch.Generator().manual_seed(0))
    print(f"texture {list(tex.shape)} float32: {tex.numel() * 4 / 1e6:.1f} MB")
    times = {1: [], 2: []}
    for _ in range(RUNS):
        for threads in times:  # interleaved, so a neighbour's load hits both alike
            times[threads].append(timed(lambda: _core.fingerprint(tex, threads)))
    for threads, seconds in times.items():
        report(f"fingerprint, {threads} thread{'s' if threads > 1 else ''}", seconds)

    try:
        glctx = dr.RasterizeVulkanContext()
    except RuntimeError as e:
        print(f"no Vulkan device: {e}")
        return
    print(f"device: {glctx.vulkan_device}")
    pos = torch.tensor([[[-1, -1, 0, 1], [3, -1, 0, 1], [-1, 3, 0, 1]]], dtype=torch.float32)
    tri = torch.tensor([[0, 1, 2]], dtype=torch.int32)
    rast, _ = dr.rasterize(glctx, pos, tri, (64, 64))
    uv, _ = dr.interpolate(torch.tensor([[0, 0], [2, 0], [0, 2]], dtype=torch.float32), rast, tri)
    lookup = lambda t: dr.texture(t, uv, filter_mode='linear')
    lookup(tex)  # keep it
    blind = dr.RasterizeVulkanContext()  # its fingerprint a constant: the check before fingerprints
    blind.kept_textures._fingerprint = lambda t: 0
    rast_b, _ = dr.rasterize(blind, pos, tri, (64, 64))
    uv_b, _ = dr.interpolate(torch.tensor([[0, 0], [2, 0], [0, 2]], dtype=torch.float32), rast_b, tri)
    dr.texture(tex, uv_b, filter_mode='linear')
    uploads, resident, unchecked = [], [], []
    for _ in range(RUNS):
        unchecked.append(timed(lambda: dr.texture(tex, uv_b, filter_mode='linear')))
        other = tex.clone()  # another object: an upload
        before = glctx.texture_residency
        uploads.append(timed(lambda: lookup(other)))
        upload_bytes = glctx.texture_residency['upload_bytes'] - before['upload_bytes']
        before = glctx.texture_residency
        resident.append(timed(lambda: lookup(tex)))
        assert glctx.texture_residency['uploads'] == before['uploads']
    print(f"an upload: {upload_bytes / 1e6:.1f} MB (texture_residency['upload_bytes'])")
    report("texture call that uploads", uploads)
    report("texture call on the kept copy (fingerprint included)", resident)
    report("texture call on the kept copy, no fingerprint", unchecked)


if __name__ == '__main__':
    main()
