"""Checks an installed gradraster Python package (tests/package/test_install.sh
and test_pip_install.sh run it, from a folder outside the source tree): it is
the copy under ROOT that gets imported, its version is VERSION (and the pip
metadata's, with --dist), it has the GPU path when VULKAN is ON, and
gradraster.torch rasterizes and differentiates a triangle with known coverage.
Usage: python check_python_package.py ROOT VERSION VULKAN(ON|OFF) [--dist]"""
import sys
from pathlib import Path


def fail(message):
    sys.exit(f"check_python_package: {message}")


def main():
    root, version, vulkan = Path(sys.argv[1]).resolve(), sys.argv[2], sys.argv[3]
    import gradraster
    import gradraster.torch as dr
    import torch

    where = Path(gradraster.__file__).resolve()
    if root not in where.parents:
        fail(f"imported {where}, not the package under {root}")
    if gradraster.__version__ != version:
        fail(f"gradraster.__version__ is {gradraster.__version__!r}, the CMake project VERSION is {version!r}")
    if '--dist' in sys.argv[4:]:
        from importlib.metadata import version as dist_version
        if dist_version('gradraster') != version:
            fail(f"pip's metadata says version {dist_version('gradraster')!r}, the module {version!r}")
    if gradraster._core.HAS_VULKAN != (vulkan == 'ON'):
        fail(f"HAS_VULKAN is {gradraster._core.HAS_VULKAN}, the build found Vulkan: {vulkan}")

    # The lower-left half of clip space, 4x4 pixels: pixel centres at +-0.25,
    # +-0.75; those with x + y < 0 are covered (6), x + y > 0 not (6), and the
    # 4 on the diagonal are left to the tie rule.
    pos = torch.tensor([[[-1.0, -1.0, 0.0, 1.0], [1.0, -1.0, 0.0, 1.0], [-1.0, 1.0, 0.0, 1.0]]], dtype=torch.float64)
    tri = torch.tensor([[0, 1, 2]], dtype=torch.int32)
    rast, _ = dr.rasterize(dr.RasterizeCpuContext(), pos, tri, resolution=(4, 4))
    centre = torch.tensor([-0.75, -0.25, 0.25, 0.75], dtype=torch.float64)
    side = centre[:, None] + centre[None, :]  # [row = y, column = x], row 0 at the bottom
    covered = rast[0, :, :, 3] == 1
    if not (covered[side < 0].all() and not covered[side > 0].any()):
        fail(f"coverage of the half-space triangle is wrong: {rast[0, :, :, 3].tolist()}")
    # d sum(interpolated attribute) / d attribute: each covered pixel's
    # barycentrics, which sum to 1, so the gradient sums to the pixel count.
    attr = torch.ones(3, 1, dtype=torch.float64, requires_grad=True)
    out, _ = dr.interpolate(attr, rast, tri)
    out.sum().backward()
    if abs(attr.grad.sum().item() - covered.sum().item()) > 1e-12:
        fail(f"interpolate's gradient sums to {attr.grad.sum().item()}, expected {covered.sum().item()} pixels")
    print(f"gradraster {gradraster.__version__} from {where.parent} (torch {torch.__version__}, "
          f"Vulkan {gradraster._core.HAS_VULKAN}): rasterize and interpolate's gradient ok")


if __name__ == '__main__':
    main()
