"""nvdiffrast's documented samples run after changing the import, the context and the device.

triangle.py (nvdiffrast's first sample) was also compared against the expected
image in nvdiffrast's documentation (docs/img/tri.png): all 65,536 pixels equal
(not stored here; the checks below are analytic).
"""
import torch

import gradraster.torch as dr


def tensor(*args, **kwargs):
    return torch.tensor(*args, device='cpu', **kwargs)  # nvdiffrast's sample: device='cuda'


def test_the_triangle_sample_renders_the_documented_image():
    glctx = dr.RasterizeCpuContext()  # nvdiffrast's sample: dr.RasterizeCudaContext()
    pos = tensor([[[-0.8, -0.8, 0, 1], [0.8, -0.8, 0, 1], [-0.8, 0.8, 0, 1]]], dtype=torch.float32)
    col = tensor([[[1, 0, 0], [0, 1, 0], [0, 0, 1]]], dtype=torch.float32)
    tri = tensor([[0, 1, 2]], dtype=torch.int32)
    rast, _ = dr.rasterize(glctx, pos, tri, resolution=[256, 256])
    out, _ = dr.interpolate(col, rast, tri)
    # Pixel (row j, column i) has its centre at clip (x, y) = ((i + 0.5) / 128 - 1, (j + 0.5) / 128 - 1)
    # (row 0 at y = -1); the triangle is x > -0.8, y > -0.8, x + y < 0; centres on the hypotenuse
    # (i + j = 255) are not covered, as in nvdiffrast's image.
    j, i = torch.meshgrid(torch.arange(256.0), torch.arange(256.0), indexing='ij')
    x, y = (i + 0.5) / 128 - 1, (j + 0.5) / 128 - 1
    inside = (x > -0.8) & (y > -0.8) & (i + j < 255)
    assert torch.equal(rast[0, ..., 3] > 0, inside)
    # Colours: barycentrics of the three vertices (w = 1: linear in the pixel).
    b1, b2 = (x + 0.8) / 1.6, (y + 0.8) / 1.6
    expected = torch.stack([1 - b1 - b2, b1, b2], -1) * inside[..., None]
    assert torch.allclose(out[0], expected.float(), atol=2e-6)
