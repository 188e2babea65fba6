"""A small shadow-mapping renderer written for nvdiffrast, as third-party code is:
its context type named in annotations, the context chosen by a string, the
device a parameter. Only the import line differs from the nvdiffrast version
(tests/python/test_nvdiffrast_context_names.py runs it)."""
from typing import Tuple, Union

import torch
import gradraster.torch as dr  # was: import nvdiffrast.torch as dr

Context = Union[dr.RasterizeGLContext, dr.RasterizeCudaContext]


def make_context(kind: str, device: torch.device) -> Context:
    if kind == 'gl':
        return dr.RasterizeGLContext(output_db=False, device=device)
    if kind == 'cuda':
        return dr.RasterizeCudaContext(device=device)
    raise ValueError(f"unknown context kind {kind!r}")


def look_down(points: torch.Tensor, height: float) -> torch.Tensor:
    """Clip-space positions seen from above (an orthographic light or camera at y = height)."""
    x, y, z = points.unbind(-1)
    return torch.stack([x, z, (height - y) / height * 2 - 1, torch.ones_like(x)], -1)


def look_front(points: torch.Tensor) -> torch.Tensor:
    """Clip-space positions seen from the front and above, in perspective."""
    x, y, z = points.unbind(-1)
    w = 2.5 - (0.6 * y + 0.8 * z)
    return torch.stack([x, 0.8 * y - 0.6 * z, w - 2.0, w], -1)


class ShadowMapRenderer:
    def __init__(self, glctx: Context, resolution: int = 64, shadow_resolution: int = 64):
        self.glctx: Context = glctx
        self.resolution = resolution
        self.shadow_resolution = shadow_resolution

    def shadow_map(self, light_pos: torch.Tensor, tri: torch.Tensor) -> torch.Tensor:
        """Depth seen from the light, [1, S, S, 1] (1 where nothing is)."""
        s = self.shadow_resolution
        rast, _ = dr.rasterize(self.glctx, light_pos, tri, (s, s))
        depth = torch.where(rast[..., 3:] > 0, rast[..., 2:3], torch.ones_like(rast[..., 2:3]))
        return depth.contiguous()

    def render(self, points: torch.Tensor, tri: torch.Tensor,
               albedo: torch.Tensor) -> Tuple[torch.Tensor, torch.Tensor]:
        light_pos = look_down(points, 2.0)[None].contiguous()
        cam_pos = look_front(points)[None].contiguous()
        depth_map = self.shadow_map(light_pos, tri)
        rast, rast_db = dr.rasterize(self.glctx, cam_pos, tri, (self.resolution, self.resolution))
        # Each pixel's position in the light's view: (u, v) in the shadow map and its depth there.
        light_attr = torch.cat([light_pos[..., :2] * 0.5 + 0.5, light_pos[..., 2:3]], -1)
        in_light, _ = dr.interpolate(light_attr, rast, tri)
        occluder = dr.texture(depth_map, in_light[..., :2].contiguous(), filter_mode='linear', boundary_mode='clamp')
        lit = torch.sigmoid((occluder - in_light[..., 2:3] + 0.02) * 200.0)
        colour, _ = dr.interpolate(albedo[None], rast, tri)
        shaded = colour * (0.3 + 0.7 * lit) * (rast[..., 3:] > 0)
        return dr.antialias(shaded.contiguous(), rast, cam_pos, tri), rast_db


def scene(device: torch.device) -> Tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """A floor and a triangle floating above it, which casts a shadow on it."""
    points = torch.tensor([[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0],
                           [-0.4, 0.8, -0.3], [0.4, 0.8, -0.3], [0.0, 0.8, 0.4]], device=device)
    tri = torch.tensor([[0, 1, 2], [0, 2, 3], [4, 5, 6]], dtype=torch.int32, device=device)
    albedo = torch.tensor([[0.8, 0.8, 0.8]] * 4 + [[0.9, 0.2, 0.2]] * 3, device=device)
    return points, tri, albedo


def main(kind: str = 'cuda', device: Union[str, torch.device] = 'cuda') -> Tuple[torch.Tensor, torch.Tensor]:
    """Renders the scene and returns (image, gradient of its mean brightness w.r.t. the vertices)."""
    device = torch.device(device)
    glctx = make_context(kind, device)
    points, tri, albedo = scene(device)
    points.requires_grad_(True)
    image, _ = ShadowMapRenderer(glctx).render(points, tri, albedo)
    image.mean().backward()
    return image.detach(), points.grad
