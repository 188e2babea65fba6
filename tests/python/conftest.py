"""Shared fixtures and scenes of the gradraster.torch tests."""
import pytest
import torch

import gradraster.torch as dr


@pytest.fixture(autouse=True)
def seeded_torch():
    """Every test draws the same random numbers, whatever ran before it."""
    torch.manual_seed(0)


@pytest.fixture
def glctx():
    return dr.RasterizeCpuContext()


def two_triangles(dtype=torch.float64, requires_grad=False):
    """Two triangles sharing an edge, in perspective (w != 1), in no special position."""
    pos = torch.tensor([[[-0.71, -0.63, 0.1, 1.0], [0.83, -0.52, 0.3, 1.5],
                         [0.13, 0.77, -0.2, 0.8], [0.91, 0.86, 0.5, 1.2]]], dtype=dtype)
    tri = torch.tensor([[0, 1, 2], [1, 3, 2]], dtype=torch.int32)
    return pos.requires_grad_(requires_grad), tri


def random_mesh(seed, images=1, triangles=6, dtype=torch.float64, requires_grad=False):
    """Random triangles in front of the camera (w in [0.8, 1.6]); vertices not shared."""
    g = torch.Generator().manual_seed(seed)
    n = 3 * triangles
    xyz = torch.rand(images, n, 3, generator=g, dtype=dtype) * 1.6 - 0.8
    w = torch.rand(images, n, 1, generator=g, dtype=dtype) * 0.8 + 0.8
    pos = torch.cat([xyz[..., :2] * w, xyz[..., 2:] * w * 0.5, w], -1)
    tri = torch.arange(n, dtype=torch.int32).reshape(triangles, 3)
    return pos.requires_grad_(requires_grad), tri


def near_plane_mesh(dtype=torch.float64, requires_grad=False):
    """A triangle with one vertex behind the camera (w < 0) and one close to w = 0."""
    pos = torch.tensor([[[-0.6, -0.5, 0.2, 1.0], [0.7, -0.4, 0.1, 0.9], [0.05, 0.3, -0.4, -0.3],
                         [0.4, 0.6, 0.0, 0.05]]], dtype=dtype)
    tri = torch.tensor([[0, 1, 2], [0, 1, 3]], dtype=torch.int32)
    return pos.requires_grad_(requires_grad), tri
