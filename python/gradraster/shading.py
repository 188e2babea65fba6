"""Shading building blocks as torch functions (docs/python.md, "Shading").

The same functions, argument order, formulas and clamps as the C++
`gr::shading` (ops/shading/; docs/shading.md), so the two agree to rounding.
Everything is plain torch, so autograd gives the gradients w.r.t. every float
input, on any device torch has (`environment_light` alone calls
`gradraster.torch.texture`, CPU tensors). Conventions:

- Vectors are on the last axis, [..., 3]; per-pixel scalars (roughness,
  metallic, shininess) are [..., 1] (or 0-dim); colours are [..., C]. All
  arguments of a call broadcast against each other: a light [3] lights an
  [H, W, 3] image.
- `normal` is unit length; `light_dir` and `view_dir` are unit and point
  AWAY from the surface (towards the light, towards the viewer).
- normalize(v) = v / max(|v|, 1e-12), as C++'s gr::normalize: the zero
  vector maps to 0.
- Results are linear radiance (`linear_to_srgb` for display); float32 or
  float64, one dtype per call.
- Masks such as [n.l > 0] and the handedness sign carry no gradient; a clamp
  passes none outside its range.

Groups: colour (`srgb_to_linear`, `linear_to_srgb`), BRDFs (`lambert`,
`blinn_phong`, `ggx_distribution`, `smith_ggx_correlated`, `fresnel_schlick`,
`cook_torrance`), lights (`directional_light`, `point_light`,
`environment_light`), spherical harmonics (`sh_basis`, `sh_irradiance`,
`sh_diffuse`, `sh_directional_light`), tangent frames and normal mapping
(`vertex_tangents`, `perturb_normal`, `reflect_view`).

Bad input raises before any arithmetic, naming the function and the argument:
not a tensor, not float, mixed float dtypes (TypeError); wrong last axis,
shapes that do not broadcast, tensors on different devices (ValueError);
triangle indices out of range (IndexError).

Determinism: `vertex_tangents` sums its per-face terms with
`Tensor.index_add` (and gathers with `index_select`, whose backward is
`index_add`), which adds the rows in index order on the CPU, so its results
and gradients are bit-identical for any torch thread count (see losses.py).
The other functions are elementwise.
"""
import math

import torch

from .losses import _check_faces

__all__ = ['srgb_to_linear', 'linear_to_srgb',
           'lambert', 'blinn_phong', 'ggx_distribution', 'smith_ggx_correlated', 'fresnel_schlick', 'cook_torrance',
           'directional_light', 'point_light', 'environment_light',
           'sh_basis', 'sh_irradiance', 'sh_diffuse', 'sh_directional_light',
           'vertex_tangents', 'perturb_normal', 'reflect_view']

_EPS = 1e-12                 # normalize's floor on |v|, point_light's on the squared distance
_NV_MIN = 1e-4               # cook_torrance: n.v clamped below
_ROUGHNESS_MIN, _ROUGHNESS_MAX = 0.03, 1.0

# Real SH basis constants (Ramamoorthi & Hanrahan 2001), exact.
_Y0 = math.sqrt(1 / (4 * math.pi))      # 0.282095
_Y1 = math.sqrt(3 / (4 * math.pi))      # 0.488603
_Y2 = math.sqrt(15 / (4 * math.pi))     # 1.092548
_Y20 = math.sqrt(5 / (16 * math.pi))    # 0.315392
_Y22 = math.sqrt(15 / (16 * math.pi))   # 0.546274
# Clamped-cosine convolution per coefficient: A0 = pi, A1 = 2pi/3, A2 = pi/4.
_SH_A = (math.pi,) + (2 * math.pi / 3,) * 3 + (math.pi / 4,) * 5


# ----------------------------------------------------------------------------
# Input checks and vector helpers


def _check(fn, *args):
    """Check (name, tensor, kind) triples: kind 2, 3 or 4 is a vector [..., k];
    'scalar' is [..., 1] or 0-dim; 'any' is [..., C] with any C; None is any
    shape that takes no part in the broadcasting (checked by the caller).
    Tensors, one float dtype, one device; the leading axes (all but the last)
    broadcast against each other, and so do the last axes of the 'scalar' and
    'any' arguments."""
    dtype = device = first = None
    leading, last = [], []
    for name, t, kind in args:
        if not isinstance(t, torch.Tensor):
            raise TypeError(f"{fn}: '{name}' must be a torch.Tensor, got {type(t).__name__}")
        if t.dtype not in (torch.float32, torch.float64):
            raise TypeError(f"{fn}: '{name}' must be float32 or float64, got {t.dtype}")
        if dtype is None:
            dtype, device, first = t.dtype, t.device, name
        elif t.dtype != dtype:
            raise TypeError(f"{fn}: '{name}' is {t.dtype} but '{first}' is {dtype}: give all float inputs one dtype")
        elif t.device != device:
            raise ValueError(f"{fn}: '{name}' is on {t.device} but '{first}' is on {device}")
        if kind == 'scalar':
            if t.dim() > 0 and t.shape[-1] != 1:
                raise ValueError(f"{fn}: '{name}' must have shape [..., 1] (one value per pixel) or be 0-dim, "
                                 f"got {list(t.shape)}")
        elif kind not in ('any', None) and (t.dim() == 0 or t.shape[-1] != kind):
            raise ValueError(f"{fn}: '{name}' must have shape [..., {kind}], got {list(t.shape)}")
        if kind is None:
            continue
        leading.append(t.shape[:-1] if t.dim() > 0 else torch.Size())
        if kind in ('scalar', 'any'):
            last.append(t.shape[-1:] if t.dim() > 0 else torch.Size())
    try:
        torch.broadcast_shapes(*leading)
        torch.broadcast_shapes(*last)
    except RuntimeError:
        shapes = ', '.join(f"'{name}' {list(t.shape)}" for name, t, kind in args if kind is not None)
        raise ValueError(f"{fn}: the shapes of {shapes} do not broadcast against each other") from None


def _dot(a, b):
    """Dot products over the last axis, keeping it: [..., 1]."""
    return (a * b).sum(-1, keepdim=True)


def _cross(a, b):
    a0, a1, a2 = a[..., 0:1], a[..., 1:2], a[..., 2:3]
    b0, b1, b2 = b[..., 0:1], b[..., 1:2], b[..., 2:3]
    return torch.cat([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], -1)


def _normalize(v):
    """v / max(|v|, 1e-12) (C++ gr::normalize): 0 for the zero vector, with a finite gradient there."""
    return v / torch.linalg.vector_norm(v, dim=-1, keepdim=True).clamp(min=_EPS)


def _positive_part(x):
    """max(x, 0); no gradient where x < 0."""
    return x.clamp(min=0.0)


# ----------------------------------------------------------------------------
# Colour (IEC 61966-2-1)


def srgb_to_linear(x):
    """sRGB-encoded values to linear: x / 12.92 for x <= 0.04045, else ((x + 0.055) / 1.055)^2.4.

    No clamp: x > 1 follows the power branch, x < 0 the linear one. At the
    threshold itself the gradient is the linear branch's (1 / 12.92)."""
    _check('srgb_to_linear', ('x', x, 'any'))
    power = ((x.clamp(min=0.04045) + 0.055) / 1.055) ** 2.4  # clamped: no NaN (or its gradient) off the branch
    return torch.where(x <= 0.04045, x / 12.92, power)


def linear_to_srgb(x):
    """Linear values to sRGB encoding: 12.92 x for x <= 0.0031308, else 1.055 x^(1/2.4) - 0.055.

    No clamp (values above 1 stay above 1). At the threshold the gradient is
    the linear branch's (12.92)."""
    _check('linear_to_srgb', ('x', x, 'any'))
    power = 1.055 * x.clamp(min=0.0031308) ** (1 / 2.4) - 0.055
    return torch.where(x <= 0.0031308, 12.92 * x, power)


# ----------------------------------------------------------------------------
# BRDFs: each returns BRDF x cosine, the radiance reflected for unit incoming radiance


def lambert(albedo, normal, light_dir):
    """Ideal diffuse: albedo * max(n.l, 0) / pi -> [..., C]."""
    _check('lambert', ('albedo', albedo, 'any'), ('normal', normal, 3), ('light_dir', light_dir, 3))
    return albedo * _positive_part(_dot(normal, light_dir)) / math.pi


def _safe_power(base, exponent):
    """base^exponent for base >= 0 with finite gradients at base == 0: the value
    is pow's (0^s), the base gets no gradient there, and pow gives the exponent
    none (torch masks log(0))."""
    positive = base > 0
    safe = torch.where(positive, base, torch.ones_like(base))
    return torch.where(positive, safe ** exponent, base.detach() ** exponent)


def blinn_phong(albedo, specular, shininess, normal, light_dir, view_dir):
    """Blinn-Phong: h = normalize(l + v),
    albedo * max(n.l, 0) / pi + specular * max(n.h, 0)^shininess * [n.l > 0] -> [..., C].

    The step [n.l > 0] (no gradient) keeps a light behind the surface from
    leaving a highlight. albedo, specular [..., C]; shininess [..., 1]."""
    _check('blinn_phong', ('albedo', albedo, 'any'), ('specular', specular, 'any'), ('shininess', shininess, 'scalar'),
           ('normal', normal, 3), ('light_dir', light_dir, 3), ('view_dir', view_dir, 3))
    h = _normalize(light_dir + view_dir)
    n_dot_l = _dot(normal, light_dir)
    lit = (n_dot_l > 0).to(n_dot_l.dtype)
    highlight = _safe_power(_positive_part(_dot(normal, h)), shininess)
    return albedo * _positive_part(n_dot_l) / math.pi + specular * highlight * lit


def ggx_distribution(n_dot_h, alpha):
    """GGX / Trowbridge-Reitz normal distribution (Walter et al. 2007):
    D = alpha^2 / (pi (n_dot_h^2 (alpha^2 - 1) + 1)^2). Elementwise; alpha > 0
    (alpha = 0 divides by zero at n_dot_h = 1)."""
    _check('ggx_distribution', ('n_dot_h', n_dot_h, 'any'), ('alpha', alpha, 'any'))
    a2 = alpha * alpha
    d = n_dot_h * n_dot_h * (a2 - 1) + 1
    return a2 / (math.pi * d * d)


def smith_ggx_correlated(n_dot_v, n_dot_l, alpha):
    """Height-correlated Smith visibility V = G2 / (4 n.l n.v) (Heitz 2014, eq. 99;
    Filament; glTF 2.0 appendix B):
    0.5 / (n_dot_l sqrt(n_dot_v^2 (1 - alpha^2) + alpha^2) + n_dot_v sqrt(n_dot_l^2 (1 - alpha^2) + alpha^2)).
    Elementwise; finite when n_dot_v > 0 or n_dot_l > 0 and alpha > 0."""
    _check('smith_ggx_correlated', ('n_dot_v', n_dot_v, 'any'), ('n_dot_l', n_dot_l, 'any'), ('alpha', alpha, 'any'))
    a2 = alpha * alpha
    ggx_v = n_dot_l * torch.sqrt(n_dot_v * n_dot_v * (1 - a2) + a2)
    ggx_l = n_dot_v * torch.sqrt(n_dot_l * n_dot_l * (1 - a2) + a2)
    return 0.5 / (ggx_v + ggx_l)


def fresnel_schlick(cos_theta, f0):
    """Schlick's Fresnel approximation: f0 + (1 - f0) (1 - cos_theta)^5. Elementwise."""
    _check('fresnel_schlick', ('cos_theta', cos_theta, 'any'), ('f0', f0, 'any'))
    return f0 + (1 - f0) * (1 - cos_theta) ** 5


def cook_torrance(base_color, metallic, roughness, normal, light_dir, view_dir):
    """glTF 2.0 metallic-roughness BRDF x cosine (glTF 2.0 appendix B) -> [..., C]:

        roughness_c = clamp(roughness, 0.03, 1) (no gradient outside), alpha = roughness_c^2
        h = normalize(l + v); NL = max(n.l, 0), NV = max(n.v, 1e-4), NH = max(n.h, 0), VH = max(v.h, 0)
        f0 = 0.04 (1 - metallic) + base_color metallic;  F = fresnel_schlick(VH, f0)
        diffuse = (1 - F) (1 - metallic) base_color / pi
        specular = F ggx_distribution(NH, alpha) smith_ggx_correlated(NV, NL, alpha)
        result = (diffuse + specular) NL

    base_color [..., C] (linear); metallic, roughness [..., 1]. Multiply by a
    light's radiance: cook_torrance(..., light_dir, view_dir) * radiance."""
    _check('cook_torrance', ('base_color', base_color, 'any'), ('metallic', metallic, 'scalar'),
           ('roughness', roughness, 'scalar'), ('normal', normal, 3), ('light_dir', light_dir, 3),
           ('view_dir', view_dir, 3))
    alpha = roughness.clamp(_ROUGHNESS_MIN, _ROUGHNESS_MAX) ** 2
    h = _normalize(light_dir + view_dir)
    nl = _positive_part(_dot(normal, light_dir))
    nv = _dot(normal, view_dir).clamp(min=_NV_MIN)
    nh = _positive_part(_dot(normal, h))
    vh = _positive_part(_dot(view_dir, h))
    f0 = 0.04 * (1 - metallic) + base_color * metallic
    f = fresnel_schlick(vh, f0)
    diffuse = (1 - f) * (1 - metallic) * base_color / math.pi
    specular = f * ggx_distribution(nh, alpha) * smith_ggx_correlated(nv, nl, alpha)
    return (diffuse + specular) * nl


# ----------------------------------------------------------------------------
# Lights: each returns (direction to the light [..., 3], unit; incoming radiance [..., C])


def directional_light(direction, radiance):
    """A distant light: (normalize(direction), radiance). direction [..., 3]
    points towards the light; radiance [..., C]."""
    _check('directional_light', ('direction', direction, 3), ('radiance', radiance, 'any'))
    return _normalize(direction), radiance


def point_light(light_position, intensity, position):
    """A point light at light_position seen from surface points `position`:
    (normalize(light_position - position), intensity / max(|light_position - position|^2, 1e-12))."""
    _check('point_light', ('light_position', light_position, 3), ('intensity', intensity, 'any'),
           ('position', position, 3))
    d = light_position - position
    return _normalize(d), intensity / _dot(d, d).clamp(min=_EPS)


def environment_light(cube_map, direction, direction_da=None, mip_level_bias=None, filter_mode='auto',
                      max_mip_level=None):
    """Radiance [..., C] arriving from `direction` [..., 3] (need not be unit;
    the zero vector gives 0), looked up in a cube map with
    gradraster.torch.texture(..., boundary_mode='cube') (docs/cube_maps.md:
    faces +X, -X, +Y, -Y, +Z, -Z, OpenGL's orientation, seamless bilinear).

    cube_map: [6, S, S, C] for all directions, or [B, 6, S, S, C] with
    direction [B, ..., 3]. By default bilinear on level 0 (no mips);
    `direction_da` [..., 6] (d direction / dX, d direction / dY, as texture's
    uv_da) or `mip_level_bias` [...] select mip levels as in texture
    (filter_mode 'auto' then means trilinear). CPU tensors (the texture op's).
    Differentiable w.r.t. cube_map, direction, direction_da and mip_level_bias."""
    from . import torch as dr  # the compiled module, only needed here
    fn = 'environment_light'
    _check(fn, ('cube_map', cube_map, None), ('direction', direction, 3))
    if cube_map.dim() not in (4, 5) or cube_map.shape[-4] != 6 or cube_map.shape[-3] != cube_map.shape[-2]:
        raise ValueError(f"{fn}: 'cube_map' must have shape [6, S, S, C] or [B, 6, S, S, C] (6 square faces), "
                         f"got {list(cube_map.shape)}")
    if cube_map.device.type != 'cpu':
        raise ValueError(f"{fn}: 'cube_map' is on {cube_map.device}; the cube-map lookup runs on the CPU")
    batched = cube_map.dim() == 5
    if batched and (direction.dim() < 2 or direction.shape[0] != cube_map.shape[0]):
        raise ValueError(f"{fn}: a batched 'cube_map' {list(cube_map.shape)} needs 'direction' of shape "
                         f"[{cube_map.shape[0]}, ..., 3], got {list(direction.shape)}")
    lead = direction.shape[:-1]
    batch = cube_map.shape[0] if batched else 1
    tex = cube_map.contiguous() if batched else cube_map[None].contiguous()
    rows = (batch, 1, -1)

    def flat(name, t, last):
        _check(fn, ('direction', direction, 3), (name, t, None))
        want = tuple(lead) + ((last,) if last else ())
        if tuple(t.shape) != want:
            raise ValueError(f"{fn}: '{name}' must have shape {list(want)}, got {list(t.shape)}")
        return t.reshape(rows + ((last,) if last else ())).contiguous()

    da = flat('direction_da', direction_da, 6) if direction_da is not None else None
    bias = flat('mip_level_bias', mip_level_bias, 0) if mip_level_bias is not None else None
    out = dr.texture(tex, direction.reshape(rows + (3,)).contiguous(), da, bias, filter_mode=filter_mode,
                     boundary_mode='cube', max_mip_level=max_mip_level)
    return out.reshape(tuple(lead) + (cube_map.shape[-1],))


# ----------------------------------------------------------------------------
# Spherical harmonics up to order 2 (Ramamoorthi & Hanrahan 2001, "An Efficient
# Representation for Irradiance Environment Maps")


def sh_basis(direction):
    """The 9 real SH basis values at unit directions [..., 3] -> [..., 9], in the
    order (0,0), (1,-1), (1,0), (1,1), (2,-2), (2,-1), (2,0), (2,1), (2,2):
    Y00 = sqrt(1/(4pi)); Y1-1, Y10, Y11 = sqrt(3/(4pi)) (y, z, x);
    Y2-2, Y2-1, Y21 = sqrt(15/(4pi)) (xy, yz, xz); Y20 = sqrt(5/(16pi)) (3z^2 - 1);
    Y22 = sqrt(15/(16pi)) (x^2 - y^2). `direction` is used as given (not normalized)."""
    _check('sh_basis', ('direction', direction, 3))
    x, y, z = direction[..., 0:1], direction[..., 1:2], direction[..., 2:3]
    return torch.cat([torch.full_like(x, _Y0),
                      _Y1 * y, _Y1 * z, _Y1 * x,
                      _Y2 * x * y, _Y2 * y * z, _Y20 * (3 * z * z - 1), _Y2 * x * z, _Y22 * (x * x - y * y)], -1)


def _check_sh(fn, sh):
    if sh.dim() != 2 or sh.shape[0] != 9:
        raise ValueError(f"{fn}: 'sh' must have shape [9, C] (coefficients of l <= 2, C channels), got {list(sh.shape)}")


def sh_irradiance(normal, sh):
    """Irradiance E(n) = sum_lm A_l L_lm Y_lm(n), A0 = pi, A1 = 2pi/3, A2 = pi/4,
    of an environment with SH radiance coefficients `sh` [9, C]
    (L_lm = integral of L(w) Y_lm(w) dw). normal [..., 3] unit -> [..., C]."""
    _check('sh_irradiance', ('normal', normal, 3), ('sh', sh, None))
    _check_sh('sh_irradiance', sh)
    basis = sh_basis(normal)
    scaled = sh * sh.new_tensor(_SH_A)[:, None]
    irradiance = basis[..., 0:1] * scaled[0]
    for k in range(1, 9):  # a fixed order of the 9 terms
        irradiance = irradiance + basis[..., k:k + 1] * scaled[k]
    return irradiance


def sh_diffuse(albedo, normal, sh):
    """Lambertian shading under an SH environment: albedo * sh_irradiance(normal, sh) / pi -> [..., C]."""
    fn = 'sh_diffuse'
    _check(fn, ('albedo', albedo, 'any'), ('normal', normal, 3), ('sh', sh, None))
    _check_sh(fn, sh)
    if albedo.dim() > 0 and albedo.shape[-1] not in (1, sh.shape[1]):
        raise ValueError(f"{fn}: 'albedo' has {albedo.shape[-1]} channels but 'sh' has {sh.shape[1]}")
    return albedo * sh_irradiance(normal, sh) / math.pi


def sh_directional_light(direction, radiance):
    """SH coefficients of a distant light, radiance * delta(w - normalize(direction)):
    L_lm = radiance Y_lm(normalize(direction)). direction [3], radiance [C] -> [9, C]
    (leading axes broadcast: direction [..., 3], radiance [..., C] -> [..., 9, C];
    sum over them for several lights). Its irradiance approximates
    radiance * max(n . direction, 0)."""
    _check('sh_directional_light', ('direction', direction, 3), ('radiance', radiance, 'any'))
    return sh_basis(_normalize(direction))[..., :, None] * radiance[..., None, :]


# ----------------------------------------------------------------------------
# Tangent frames and normal mapping


def vertex_tangents(positions, uvs, triangles, normals):
    """Per-vertex tangent frames [V, 4] = (t, w) for normal mapping.

    positions [V, 3], uvs [V, 2], triangles [M, 3] (any integer dtype, indices
    in [0, V)), normals [V, 3] unit. Per face, with e1 = p1 - p0, e2 = p2 - p0,
    (du1, dv1) = uv1 - uv0, (du2, dv2) = uv2 - uv0, det = du1 dv2 - du2 dv1 and
    s = sign(det) (0 when det == 0):
        t_face = s (dv2 e1 - dv1 e2)   (= |det| dp/du),   b_face = s (du1 e2 - du2 e1)   (= |det| dp/dv);
    t_acc, b_acc are their sums over each vertex's faces (faces ascending);
    t = normalize(t_acc - n (n . t_acc)) (Gram-Schmidt, MikkTSpace-style) and
    w = -1 if (n x t) . b_acc < 0 else +1 (handedness: -1 for mirrored uvs; no
    gradient). A vertex whose faces all have degenerate uvs gets t = 0, w = +1.
    Differentiable w.r.t. positions, uvs and normals (s is piecewise constant)."""
    fn = 'vertex_tangents'
    _check(fn, ('positions', positions, None), ('uvs', uvs, None), ('normals', normals, None))
    if positions.dim() != 2 or positions.shape[1] != 3:
        raise ValueError(f"{fn}: 'positions' must have shape [V, 3], got {list(positions.shape)}")
    for name, t, k in (('uvs', uvs, 2), ('normals', normals, 3)):
        if t.dim() != 2 or t.shape[1] != k or t.shape[0] != positions.shape[0]:
            raise ValueError(f"{fn}: '{name}' must have shape [V, {k}] with V = {positions.shape[0]} "
                             f"(the rows of 'positions'), got {list(t.shape)}")
    faces = _check_faces(triangles, positions.shape[0], positions.device, fn, 'triangles', 'positions', 'M')

    def corner(values, k):
        return values.index_select(0, faces[:, k])

    p0, uv0 = corner(positions, 0), corner(uvs, 0)
    e1, e2 = corner(positions, 1) - p0, corner(positions, 2) - p0
    d1, d2 = corner(uvs, 1) - uv0, corner(uvs, 2) - uv0
    du1, dv1, du2, dv2 = d1[:, 0:1], d1[:, 1:2], d2[:, 0:1], d2[:, 1:2]
    s = torch.sign(du1 * dv2 - du2 * dv1).detach()
    t_face = s * (dv2 * e1 - dv1 * e2)
    b_face = s * (du1 * e2 - du2 * e1)
    # Each face's term to its three corners, rows in the order (face 0: corners
    # 0, 1, 2; face 1: ...), summed in that order.
    index = faces.reshape(-1)
    t_acc = positions.new_zeros(positions.shape).index_add(0, index, t_face.repeat_interleave(3, dim=0))
    b_acc = positions.new_zeros(positions.shape).index_add(0, index, b_face.repeat_interleave(3, dim=0))
    t = _normalize(t_acc - normals * _dot(normals, t_acc))
    w = 1 - 2 * (_dot(_cross(normals, t), b_acc) < 0).to(t.dtype)  # a mask: no gradient
    return torch.cat([t, w], -1)


def perturb_normal(normal, tangent, texel):
    """Tangent-space normal mapping (OpenGL convention: green = +v) -> [..., 3]:
    m = 2 texel - 1;  t = normalize(tangent.xyz - n (n . tangent.xyz));
    b = tangent.w (n x t);  n' = normalize(t m.x + b m.y + n m.z).
    normal [..., 3] unit, tangent [..., 4] (vertex_tangents' (t, w),
    interpolated), texel [..., 3] in [0, 1]. The texel (0.5, 0.5, 1) returns
    n; a zero tangent gives normalize(n m.z)."""
    _check('perturb_normal', ('normal', normal, 3), ('tangent', tangent, 4), ('texel', texel, 3))
    m = 2 * texel - 1
    tangent_xyz, handedness = tangent[..., 0:3], tangent[..., 3:4]
    t = _normalize(tangent_xyz - normal * _dot(normal, tangent_xyz))
    b = handedness * _cross(normal, t)
    return _normalize(t * m[..., 0:1] + b * m[..., 1:2] + normal * m[..., 2:3])


def reflect_view(view_dir, normal):
    """The mirror direction of view_dir about normal: 2 (n.v) n - v -> [..., 3]
    (for environment lookups: environment_light(cube_map, reflect_view(v, n)))."""
    _check('reflect_view', ('view_dir', view_dir, 3), ('normal', normal, 3))
    return 2 * _dot(normal, view_dir) * normal - view_dir
