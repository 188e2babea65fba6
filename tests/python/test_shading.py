"""gradraster.shading: every function against the independent reference table
(tests/data/shading_reference, plain-float evaluations of the published
formulas), closed forms (GGX normalization, the SH addition theorem, white
furnaces, hand-worked tangent frames), gradcheck in float64 for every float
input on random inputs and hard cases, determinism and bad input."""
import math
import os

import pytest
import torch

import gradraster.torch as dr
from gradraster import shading as S

F64 = torch.float64
REFERENCE = os.path.join(os.path.dirname(__file__), '..', 'data', 'shading_reference', 'shading_reference.txt')


def t64(*values):
    return torch.tensor(values, dtype=F64)


def unit(v):
    return v / v.norm(dim=-1, keepdim=True)


def random_units(g, *shape):
    return unit(torch.randn(*shape, 3, generator=g, dtype=F64))


def gradients_match(fn, *inputs):
    """gradcheck in float64 w.r.t. every input (fresh leaves)."""
    inputs = tuple(x.detach().clone().to(F64).requires_grad_(True) for x in inputs)
    return torch.autograd.gradcheck(fn, inputs, eps=1e-6, atol=1e-7, rtol=1e-5)


def towards(n, n_dot, g):
    """Unit vectors d with n . d = n_dot (up to rounding), in random directions about the unit vectors n."""
    side = unit(torch.cross(n, random_units(g, *n.shape[:-1]), dim=-1))
    return n_dot * n + math.sqrt(1 - n_dot * n_dot) * side


def frame_with(n_dot, g, count=6):
    """count random unit normals n and unit vectors d with n . d = n_dot."""
    n = random_units(g, count)
    return n, towards(n, n_dot, g)


# ----------------------------------------------------------------------------
# The independent reference table (tests/data/shading_reference, written by
# make_shading_reference.py there: one row per case, the function's name, its
# inputs then its outputs, 17 significant digits; ARITY gives the sizes)

ARITY = {  # name: (input sizes, output size)
    'srgb_to_linear': ([1], 1), 'linear_to_srgb': ([1], 1), 'lambert': ([3, 3, 3], 3),
    'blinn_phong': ([3, 3, 1, 3, 3, 3], 3), 'ggx_distribution': ([1, 1], 1), 'smith_ggx_correlated': ([1, 1, 1], 1),
    'fresnel_schlick': ([1, 3], 3), 'cook_torrance': ([3, 1, 1, 3, 3, 3], 3), 'point_light': ([3, 3, 3], 6),
    'sh_basis': ([3], 9), 'sh_irradiance': ([3, 27], 3), 'perturb_normal': ([3, 4, 3], 3)}


def reference_rows():
    with open(REFERENCE) as f:
        return [line.split() for line in f if line.strip()]


def evaluate_row(row):
    name, numbers = row[0], [float(x) for x in row[1:]]
    sizes, out_size = ARITY[name]
    assert len(numbers) == sum(sizes) + out_size, f'{name}: {len(numbers)} numbers'
    args, k = [], 0
    for size in sizes:
        args.append(torch.tensor(numbers[k:k + size], dtype=F64))
        k += size
    if name == 'sh_irradiance':
        args[1] = args[1].reshape(9, 3)
    result = getattr(S, name)(*args)
    if name == 'point_light':
        result = torch.cat(result)
    return result, torch.tensor(numbers[k:], dtype=F64)


def test_the_reference_table_has_all_75_rows_and_only_known_functions():
    rows = reference_rows()
    assert len(rows) == 75
    assert {r[0] for r in rows} == set(ARITY)


@pytest.mark.parametrize('index', range(75))
def test_each_reference_row_agrees_to_1e_12(index):
    row = reference_rows()[index]
    got, want = evaluate_row(row)
    assert got.shape == want.shape
    assert torch.allclose(got, want, rtol=1e-12, atol=1e-15), (row[0], got, want)


def test_the_reference_comparison_can_fail():
    row = next(r for r in reference_rows() if r[0] == 'cook_torrance')
    row = row[:-1] + [repr(float(row[-1]) * (1 + 1e-11))]
    got, want = evaluate_row(row)
    assert not torch.allclose(got, want, rtol=1e-12, atol=1e-15)


# ----------------------------------------------------------------------------
# Colour


def test_srgb_known_values_and_round_trip():
    assert S.srgb_to_linear(t64(0.5)).item() == pytest.approx(0.21404114048223255, rel=1e-15)
    assert S.linear_to_srgb(t64(0.21404114048223255)).item() == pytest.approx(0.5, rel=1e-15)
    x = torch.linspace(-0.2, 1.5, 1701, dtype=F64)
    assert torch.allclose(S.linear_to_srgb(S.srgb_to_linear(x)), x, atol=1e-7)  # the IEC constants invert to ~1e-8
    assert torch.equal(S.srgb_to_linear(t64(-0.1, 0.0, 0.04045)), t64(-0.1, 0.0, 0.04045) / 12.92)
    assert torch.equal(S.linear_to_srgb(t64(-0.01, 0.0, 0.0031308)), 12.92 * t64(-0.01, 0.0, 0.0031308))


def test_srgb_gradients_beside_the_branch_thresholds_and_the_linear_branch_at_them():
    for fn, threshold, slope in ((S.srgb_to_linear, 0.04045, 1 / 12.92), (S.linear_to_srgb, 0.0031308, 12.92)):
        x = t64(-0.3, 0.0, threshold - 1e-5, threshold + 1e-5, 0.5, 1.0, 1.7)
        assert gradients_match(fn, x)
        at = t64(threshold).requires_grad_(True)
        fn(at).backward()
        assert at.grad.item() == pytest.approx(slope, rel=1e-14)


# ----------------------------------------------------------------------------
# BRDFs: closed forms


def test_ggx_peak_is_one_over_pi_alpha_squared_and_the_distribution_is_normalized():
    for alpha in (0.04, 0.2, 0.5, 1.0):
        # (alpha^2 - 1) + 1 cancels: relative rounding ~ 1e-16 / alpha^2
        peak = S.ggx_distribution(t64(1.0), t64(alpha)).item()
        assert peak == pytest.approx(1 / (math.pi * alpha ** 2), rel=1e-12)
        # integral of D(h) (n.h) over the hemisphere = 1: 2 pi int D(cos t) cos t sin t dt, t in [0, pi/2]
        t = (torch.arange(200000, dtype=F64) + 0.5) / 200000 * (math.pi / 2)
        integral = math.pi ** 2 * (S.ggx_distribution(torch.cos(t), t64(alpha)) * torch.cos(t) * torch.sin(t)).mean()
        assert integral.item() == pytest.approx(1.0, abs=1e-6)


def test_smith_visibility_closed_forms():
    nv, nl = t64(0.3, 0.8, 1.0), t64(0.6, 0.2, 1.0)
    # alpha = 1: both square roots are 1
    assert torch.allclose(S.smith_ggx_correlated(nv, nl, t64(1.0)), 0.5 / (nl + nv), rtol=1e-15)
    # alpha -> 0: G2 -> 1, V -> 1 / (4 n.l n.v)
    assert torch.allclose(S.smith_ggx_correlated(nv, nl, t64(1e-7)), 1 / (4 * nl * nv), rtol=1e-12)


def test_fresnel_is_f0_at_normal_incidence_and_one_at_grazing():
    f0 = t64(0.04, 0.5, 0.95)
    assert torch.equal(S.fresnel_schlick(t64(1.0), f0), f0)
    assert torch.allclose(S.fresnel_schlick(t64(0.0), f0), torch.ones(3, dtype=F64), rtol=1e-15)


def hemisphere_integral(integrand, n=1600):
    """int over the upper hemisphere (+z) of integrand(l [P, 3]) [P, C] dw, midpoint rule in (cos theta, phi)."""
    c = (torch.arange(n, dtype=F64) + 0.5) / n
    phi = (torch.arange(2 * n, dtype=F64) + 0.5) / (2 * n) * 2 * math.pi
    c, phi = torch.meshgrid(c, phi, indexing='ij')
    s = torch.sqrt(1 - c * c)
    l = torch.stack([s * torch.cos(phi), s * torch.sin(phi), c], -1).reshape(-1, 3)
    return integrand(l).mean(0) * 2 * math.pi


def test_white_furnace_lambert_reflects_its_albedo():
    z = t64(0.0, 0.0, 1.0)
    albedo = t64(1.0, 0.5, 0.25)
    assert torch.allclose(hemisphere_integral(lambda l: S.lambert(albedo, z, l), n=400), albedo, rtol=1e-5)


def test_white_furnace_of_a_white_metal_seen_from_above():
    z = t64(0.0, 0.0, 1.0)
    one = torch.ones(3, dtype=F64)
    # alpha = 1: D = 1/pi, F = 1, V = 0.5 / (n.l + 1), so the reflected energy is
    # 2 int_0^1 0.5 c / (1 + c) dc = 1 - ln 2
    rough = hemisphere_integral(lambda l: S.cook_torrance(one, t64(1.0), t64(1.0), z, l, z))
    assert torch.allclose(rough, torch.full((3,), 1 - math.log(2), dtype=F64), rtol=1e-6)
    # single-scattering GGX loses little energy at alpha = 0.04 (the masking-shadowing only)
    smooth = hemisphere_integral(lambda l: S.cook_torrance(one, t64(1.0), t64(0.2), z, l, z))
    assert 0.99 < smooth[0].item() < 1.0


def test_cook_torrance_clamps_roughness_and_n_dot_v_and_is_zero_below_the_horizon():
    g = torch.Generator().manual_seed(5)
    n, l = frame_with(0.6, g)
    v = unit(n + 0.3 * random_units(g, 6))
    base, metallic = torch.rand(6, 3, generator=g, dtype=F64), torch.rand(6, 1, generator=g, dtype=F64)
    ct = lambda r, v=v, l=l: S.cook_torrance(base, metallic, torch.full((6, 1), r, dtype=F64), n, l, v)
    assert torch.equal(ct(0.01), ct(0.03)) and torch.equal(ct(-1.0), ct(0.03))
    assert torch.equal(ct(2.0), ct(1.0)) and not torch.equal(ct(0.5), ct(1.0))
    # a view below the horizon: the terms with n . v = 1e-4, the half vector from the true v
    for n_dot_v in (-0.5, -1e-5, 0.5e-4):
        below = towards(n, n_dot_v, g)
        r, alpha = 0.5, 0.25
        h = unit(l + below)
        nl, nh, vh = (n * l).sum(-1, keepdim=True), (n * h).sum(-1, keepdim=True), (below * h).sum(-1, keepdim=True)
        f = S.fresnel_schlick(vh.clamp(min=0), 0.04 * (1 - metallic) + base * metallic)
        want = ((1 - f) * (1 - metallic) * base / math.pi + f * S.ggx_distribution(nh.clamp(min=0), t64(alpha))
                * S.smith_ggx_correlated(t64(1e-4), nl, t64(alpha))) * nl
        assert torch.allclose(ct(r, v=below), want, rtol=1e-14)
    dark = towards(n, -0.2, g)
    assert torch.equal(S.cook_torrance(base, metallic, t64(0.5), n, dark, v), torch.zeros(6, 3, dtype=F64))


def test_cook_torrance_with_metallic_one_has_no_diffuse_and_base_color_as_f0():
    z = t64(0.0, 0.0, 1.0)
    base = t64(0.9, 0.6, 0.3)
    got = S.cook_torrance(base, t64(1.0), t64(0.5), z, z, z)  # l = v = n: F = f0, D = 1/(pi alpha^2), V = 1/4
    alpha = 0.25
    assert torch.allclose(got, base / (math.pi * alpha ** 2) / 4, rtol=1e-14)


def test_blinn_phong_has_no_highlight_from_a_light_behind_the_surface():
    z = t64(0.0, 0.0, 1.0)
    l = unit(t64(0.0, 0.3, -0.1))  # below the horizon
    v = unit(t64(0.0, -0.1, 1.0))  # h close to n: a strong highlight without the mask
    albedo, spec = t64(0.5, 0.5, 0.5), t64(1.0, 1.0, 1.0)
    assert torch.equal(S.blinn_phong(albedo, spec, t64(8.0), z, l, v), torch.zeros(3, dtype=F64))
    up = unit(t64(0.0, 0.3, 1.0))
    h = unit(up + v)
    want = albedo * up[2] / math.pi + spec * h[2] ** 8
    assert torch.allclose(S.blinn_phong(albedo, spec, t64(8.0), z, up, v), want, rtol=1e-14)


def test_functions_broadcast_a_light_over_an_image_and_float32_agrees_with_float64():
    g = torch.Generator().manual_seed(2)
    n = random_units(g, 4, 5)
    v = unit(n + random_units(g, 4, 5))
    base, rough, metal = torch.rand(4, 5, 3, generator=g, dtype=F64), torch.rand(4, 5, 1, generator=g, dtype=F64), t64(0.3)
    l = unit(t64(0.2, 0.5, 0.8))
    out = S.cook_torrance(base, metal, rough, n, l, v)
    assert out.shape == (4, 5, 3)
    per_pixel = S.cook_torrance(base, metal.expand(4, 5, 1), rough, n, l.expand(4, 5, 3), v)
    assert torch.equal(out, per_pixel)
    out32 = S.cook_torrance(*(x.float() for x in (base, metal, rough, n, l, v)))
    assert out32.dtype == torch.float32 and torch.allclose(out32.double(), out, rtol=1e-5, atol=1e-6)


# ----------------------------------------------------------------------------
# BRDFs: gradients


def brdf_inputs(seed, n_dot_l=None, n_dot_v=None, count=6):
    """Random unit n, l, v (n . l and n . v given or random, mostly positive), colours, metallic, roughness, shininess."""
    g = torch.Generator().manual_seed(seed)
    n = random_units(g, count)
    direction = lambda n_dot: unit(n + 0.8 * random_units(g, count)) if n_dot is None else towards(n, n_dot, g)
    l, v = direction(n_dot_l), direction(n_dot_v)
    scalar = lambda lo, hi: lo + (hi - lo) * torch.rand(count, 1, generator=g, dtype=F64)
    return dict(n=n, l=l, v=v, colour=0.1 + 0.8 * torch.rand(count, 3, generator=g, dtype=F64),
                colour2=torch.rand(count, 3, generator=g, dtype=F64), metallic=scalar(0, 1),
                roughness=scalar(0.1, 0.9), shininess=scalar(1, 40))


@pytest.mark.parametrize('case', ['random', 'grazing light', 'light just below', 'grazing view'])
def test_lambert_and_blinn_phong_gradients(case):
    kw = {'random': {}, 'grazing light': {'n_dot_l': 1e-3}, 'light just below': {'n_dot_l': -1e-3},
          'grazing view': {'n_dot_v': 1e-3}}[case]
    x = brdf_inputs(3, **kw)
    assert gradients_match(S.lambert, x['colour'], x['n'], x['l'])
    assert gradients_match(S.blinn_phong, x['colour'], x['colour2'], x['shininess'], x['n'], x['l'], x['v'])


def test_blinn_phong_gradients_with_a_shininess_below_one_and_n_dot_h_at_zero_are_finite():
    z = t64(0.0, 0.0, 1.0)
    l, v = t64(0.6, 0.0, 0.8), t64(-0.6, 0.0, 0.8)  # h = (0, 0, 1)
    inputs = [t64(0.5, 0.5, 0.5), t64(1.0, 1.0, 1.0), t64(0.5), t64(1.0, 0.0, 0.0), l, v]
    inputs = [x.requires_grad_(True) for x in inputs]  # normal (1, 0, 0): n.l = 0.6 > 0, n.h = 0
    out = S.blinn_phong(*inputs)
    out.sum().backward()
    assert all(torch.isfinite(x.grad).all() for x in inputs)
    assert out[0].item() == pytest.approx(0.5 * 0.6 / math.pi, rel=1e-14)


@pytest.mark.parametrize('case', ['random', 'grazing light', 'light just below', 'n.v just above 1e-4',
                                  'n.v just below 1e-4', 'view below the horizon'])
def test_cook_torrance_gradients_at_grazing_angles(case):
    kw = {'random': {}, 'grazing light': {'n_dot_l': 1e-3}, 'light just below': {'n_dot_l': -1e-3},
          'n.v just above 1e-4': {'n_dot_v': 1.1e-4}, 'n.v just below 1e-4': {'n_dot_v': 0.9e-4},
          'view below the horizon': {'n_dot_v': -0.3}}[case]
    x = brdf_inputs(4, **kw)
    assert gradients_match(S.cook_torrance, x['colour'], x['metallic'], x['roughness'], x['n'], x['l'], x['v'])


@pytest.mark.parametrize('roughness', [0.03 - 1e-4, 0.03 + 1e-4, 0.05, 0.5, 1 - 1e-4, 1 + 1e-4, -0.5, 3.0])
@pytest.mark.parametrize('metallic', [0.0, 1.0, 0.35])
def test_cook_torrance_gradients_at_the_roughness_clamps_and_metallic_ends(roughness, metallic):
    x = brdf_inputs(6)
    r, m = torch.full((6, 1), roughness, dtype=F64), torch.full((6, 1), metallic, dtype=F64)
    assert gradients_match(S.cook_torrance, x['colour'], m, r, x['n'], x['l'], x['v'])
    if not 0.03 <= roughness <= 1:
        r = r.requires_grad_(True)
        S.cook_torrance(x['colour'], m, r, x['n'], x['l'], x['v']).sum().backward()
        assert torch.equal(r.grad, torch.zeros_like(r))


def test_cook_torrance_with_the_light_opposite_the_view_is_zero_with_finite_gradients():
    g = torch.Generator().manual_seed(80)
    x = brdf_inputs(8)
    for n_dot_v in (0.4, -0.4, 0.0):  # l = -v: h = normalize(0) = 0
        n = x['n']
        v = towards(n, n_dot_v, g)
        inputs = [x['colour'], x['metallic'], x['roughness'], n, -v, v]
        inputs = [t.clone().requires_grad_(True) for t in inputs]
        out = S.cook_torrance(*inputs)
        out.sum().backward()
        assert torch.isfinite(out).all() and all(torch.isfinite(t.grad).all() for t in inputs)
        if n_dot_v > 0:  # the light is below the horizon
            assert torch.equal(out, torch.zeros_like(out))
        elif n_dot_v == 0:  # n.l = 0 up to rounding
            assert out.abs().max() < 1e-12


@pytest.mark.parametrize('alpha', [0.03 ** 2, 0.05, 0.4, 1.0])
def test_ggx_smith_and_fresnel_gradients(alpha):
    g = torch.Generator().manual_seed(9)
    c = torch.cat([t64(0.0, 1e-4, 1.0), torch.rand(5, generator=g, dtype=F64)])
    a = torch.full_like(c, alpha)
    # at alpha = 0.03^2 D falls from 4e5 to 0 within 1e-6 of n.h = 1, finer than finite differences resolve
    assert gradients_match(S.ggx_distribution, c.clamp(max=0.99) if alpha < 0.01 else c, a)
    assert gradients_match(S.smith_ggx_correlated, c, c.flip(0), a)
    assert gradients_match(S.fresnel_schlick, c[:, None], torch.rand(8, 3, generator=g, dtype=F64))


# ----------------------------------------------------------------------------
# Lights


def test_directional_light_normalizes_and_passes_the_radiance():
    d, rad = S.directional_light(t64(0.0, 3.0, 4.0), t64(1.0, 2.0, 3.0))
    assert torch.allclose(d, t64(0.0, 0.6, 0.8), rtol=1e-15) and torch.equal(rad, t64(1.0, 2.0, 3.0))


def test_point_light_falls_off_with_the_inverse_square_of_the_distance():
    p = torch.stack([t64(0.0, 0.0, 0.0), t64(0.0, 0.0, -1.0), t64(3.0, 4.0, 0.0)])
    d, rad = S.point_light(t64(0.0, 0.0, 1.0), t64(2.0, 4.0, 8.0), p)
    assert torch.allclose(d, unit(t64(0.0, 0.0, 1.0) - p), rtol=1e-15)
    assert torch.allclose(rad, t64(2.0, 4.0, 8.0) / t64(1.0, 4.0, 26.0)[:, None], rtol=1e-15)
    # at the light: direction 0, radiance intensity / 1e-12, both finite
    d, rad = S.point_light(t64(1.0, 2.0, 3.0), t64(1.0), t64(1.0, 2.0, 3.0))
    assert torch.equal(d, torch.zeros(3, dtype=F64)) and rad.item() == pytest.approx(1e12)


@pytest.mark.parametrize('distance', [2.0, 1e-2, 1e-3])
def test_light_gradients_including_a_point_light_near_the_surface(distance):
    g = torch.Generator().manual_seed(10)
    p = torch.randn(5, 3, generator=g, dtype=F64)
    light = p[2] + distance * random_units(g)
    assert gradients_match(S.point_light, light, torch.rand(3, generator=g, dtype=F64) * 5, p)
    assert gradients_match(S.directional_light, torch.randn(5, 3, generator=g, dtype=F64) * distance,
                           torch.rand(5, 3, generator=g, dtype=F64))


def cube_map_with_constant_faces(values):
    """[6, 2, 2, C]: face k filled with values[k]."""
    return values[:, None, None, :].expand(6, 2, 2, values.shape[1]).contiguous()


def test_environment_light_reads_each_face_at_its_centre_direction():
    values = torch.arange(18, dtype=F64).reshape(6, 3)
    axes = t64(1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1).reshape(6, 3)
    assert torch.equal(S.environment_light(cube_map_with_constant_faces(values), 2.5 * axes), values)
    constant = torch.full((6, 4, 4, 2), 0.7, dtype=F64)
    dirs = torch.randn(3, 5, 3, generator=torch.Generator().manual_seed(1), dtype=F64)
    assert torch.allclose(S.environment_light(constant, dirs), torch.full((3, 5, 2), 0.7, dtype=F64), rtol=1e-15)
    assert torch.equal(S.environment_light(constant, torch.zeros(2, 3, dtype=F64)), torch.zeros(2, 2, dtype=F64))


def test_environment_light_is_the_cube_texture_lookup_for_any_leading_shape_and_a_batch():
    g = torch.Generator().manual_seed(11)
    env = torch.rand(6, 8, 8, 3, generator=g, dtype=F64)
    dirs = torch.randn(2, 3, 4, 3, generator=g, dtype=F64)
    want = dr.texture(env[None], dirs.reshape(1, 1, 24, 3), boundary_mode='cube').reshape(2, 3, 4, 3)
    assert torch.equal(S.environment_light(env, dirs), want)
    batch = torch.rand(2, 6, 8, 8, 3, generator=g, dtype=F64)
    got = S.environment_light(batch, dirs)
    for b in range(2):
        assert torch.equal(got[b], S.environment_light(batch[b], dirs[b]))
    bias = torch.rand(2, 3, 4, generator=g, dtype=F64) * 2
    want = dr.texture(env[None], dirs.reshape(1, 1, 24, 3), mip_level_bias=bias.reshape(1, 1, 24),
                      boundary_mode='cube').reshape(2, 3, 4, 3)
    assert torch.equal(S.environment_light(env, dirs, mip_level_bias=bias), want)


def test_environment_light_gradients():
    g = torch.Generator().manual_seed(12)
    env = torch.rand(6, 4, 4, 2, generator=g, dtype=F64)
    dirs = torch.randn(7, 3, generator=g, dtype=F64)
    assert gradients_match(S.environment_light, env, dirs)
    assert gradients_match(lambda e, d: S.environment_light(e, S.reflect_view(d, unit(t64(0.3, 0.9, 0.2)))),
                           env, unit(dirs))


# ----------------------------------------------------------------------------
# Spherical harmonics


def sphere_grid(n=400):
    """Midpoint grid on the sphere in (z, phi) (equal areas), directions [P, 3]; mean * 4 pi integrates."""
    z = (torch.arange(n, dtype=F64) + 0.5) / n * 2 - 1
    phi = (torch.arange(2 * n, dtype=F64) + 0.5) / (2 * n) * 2 * math.pi
    z, phi = torch.meshgrid(z, phi, indexing='ij')
    s = torch.sqrt(1 - z * z)
    return torch.stack([s * torch.cos(phi), s * torch.sin(phi), z], -1).reshape(-1, 3)


def test_sh_basis_is_orthonormal_on_the_sphere():
    # Gauss-Legendre in z (8 nodes, exact to degree 15) times 16 equal steps in phi: exact for these degree-4 products
    import numpy
    z, wz = (torch.from_numpy(a) for a in numpy.polynomial.legendre.leggauss(8))
    phi = torch.arange(16, dtype=F64) / 16 * 2 * math.pi
    z, phi = torch.meshgrid(z, phi, indexing='ij')
    s = torch.sqrt(1 - z * z)
    d = torch.stack([s * torch.cos(phi), s * torch.sin(phi), z], -1).reshape(-1, 3)
    weight = (wz[:, None].expand(8, 16) * (2 * math.pi / 16)).reshape(-1, 1)
    y = S.sh_basis(d)
    assert torch.allclose(y.T @ (weight * y), torch.eye(9, dtype=F64), atol=1e-14)


def test_sh_basis_constants_and_order():
    x, y, z = 0.36, 0.48, 0.8
    want = t64(0.28209479177387814, 0.4886025119029199 * y, 0.4886025119029199 * z, 0.4886025119029199 * x,
               1.0925484305920792 * x * y, 1.0925484305920792 * y * z, 0.31539156525252005 * (3 * z * z - 1),
               1.0925484305920792 * x * z, 0.5462742152960396 * (x * x - y * y))
    assert torch.allclose(S.sh_basis(t64(x, y, z)), want, rtol=1e-15)


def test_sh_irradiance_of_a_directional_light_is_the_order_2_clamped_cosine():
    g = torch.Generator().manual_seed(13)
    light = random_units(g)
    sh = S.sh_directional_light(light * 3.0, t64(1.0, 0.5))  # the direction is normalized
    assert sh.shape == (9, 2)
    n = random_units(g, 50)
    c = n @ light
    # addition theorem: sum_m Y_lm(n) Y_lm(l) = (2l+1)/(4 pi) P_l(n.l), so
    # E = 1/4 + c/2 + 5/16 P_2(c) per unit radiance (0.0625 above max(c, 0) at c = 1)
    e = 0.25 + 0.5 * c + 5 / 16 * (3 * c * c - 1) / 2
    got = S.sh_irradiance(n, sh)
    assert torch.allclose(got, e[:, None] * t64(1.0, 0.5), rtol=1e-13, atol=1e-15)
    assert (got[:, 0] - c.clamp(min=0)).abs().max() < 0.1


def test_sh_of_a_constant_environment_gives_irradiance_pi_times_the_radiance():
    radiance = t64(0.2, 0.7, 1.3)
    sh = torch.zeros(9, 3, dtype=F64)
    sh[0] = radiance * 4 * math.pi * 0.28209479177387814  # L00 = integral of L Y00
    n = random_units(torch.Generator().manual_seed(14), 10)
    assert torch.allclose(S.sh_irradiance(n, sh), math.pi * radiance.expand(10, 3), rtol=1e-14)
    albedo = torch.rand(10, 3, dtype=F64)
    assert torch.allclose(S.sh_diffuse(albedo, n, sh), albedo * radiance, rtol=1e-14)


def test_sh_irradiance_agrees_with_integrating_the_projected_environment():
    """Project an environment L(w) = 1 + w.x + 2 w.z^2 (band-limited to l <= 2) by
    quadrature, then E(n) must equal the integral of L(w) max(n.w, 0) dw."""
    w = sphere_grid(300)
    env = (1 + w[:, 0] + 2 * w[:, 2] ** 2)[:, None]
    sh = S.sh_basis(w).T @ env / w.shape[0] * 4 * math.pi  # [9, 1]
    n = random_units(torch.Generator().manual_seed(15), 4)
    want = (env.T * (n @ w.T).clamp(min=0)).mean(1) * 4 * math.pi
    assert torch.allclose(S.sh_irradiance(n, sh)[:, 0], want, rtol=2e-4)


def test_sh_gradients():
    g = torch.Generator().manual_seed(16)
    n = torch.randn(4, 5, 3, generator=g, dtype=F64)
    sh = torch.randn(9, 3, generator=g, dtype=F64)
    assert gradients_match(S.sh_basis, n)
    assert gradients_match(S.sh_irradiance, n, sh)
    assert gradients_match(S.sh_diffuse, torch.rand(5, 3, generator=g, dtype=F64), n, sh)
    assert gradients_match(S.sh_directional_light, torch.randn(3, generator=g, dtype=F64),
                           torch.rand(3, generator=g, dtype=F64))
    assert gradients_match(S.sh_directional_light, torch.randn(4, 3, generator=g, dtype=F64),
                           torch.rand(4, 2, generator=g, dtype=F64))


# ----------------------------------------------------------------------------
# Tangent frames and normal mapping


def quad(uv_of):
    """Unit square in z = 0 as two counter-clockwise triangles, uvs uv_of(x, y), normals +z."""
    pos = t64(0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0).reshape(4, 3)
    uvs = torch.stack([uv_of(p[0], p[1]) for p in pos])
    tri = torch.tensor([[0, 1, 2], [0, 2, 3]], dtype=torch.int32)
    return pos, uvs, tri, t64(0, 0, 1).expand(4, 3).contiguous()


def test_a_quad_with_uv_equal_xy_has_tangent_x_and_right_handedness():
    tangents = S.vertex_tangents(*quad(lambda x, y: torch.stack([x, y])))
    assert torch.equal(tangents, t64(1, 0, 0, 1).expand(4, 4))


def test_mirrored_u_gives_the_tangent_minus_x_and_handedness_minus_one():
    tangents = S.vertex_tangents(*quad(lambda x, y: torch.stack([1 - x, y])))
    assert torch.equal(tangents, t64(-1, 0, 0, -1).expand(4, 4))
    # the bitangent perturb_normal builds, w (n x t), is +y = dp/dv in both cases
    n = t64(0, 0, 1)
    for frame in (tangents[0], S.vertex_tangents(*quad(lambda x, y: torch.stack([x, y])))[0]):
        assert torch.allclose(S.perturb_normal(n, frame, t64(0.5, 1.0, 0.5)), t64(0, 1, 0), atol=1e-15)


def test_an_affine_uv_map_gives_the_projected_dp_du_and_the_sign_of_its_determinant():
    g = torch.Generator().manual_seed(17)
    for _ in range(4):
        a = torch.randn(2, 2, generator=g, dtype=F64)
        pos, uvs, tri, normals = quad(lambda x, y: a @ torch.stack([x, y]))
        dp_du = torch.cat([torch.linalg.inv(a)[:, 0], t64(0.0)])  # p = A^-1 uv
        got = S.vertex_tangents(pos, uvs, tri, normals)
        assert torch.allclose(got[:, :3], unit(dp_du).expand(4, 3), atol=1e-14)
        assert torch.equal(got[:, 3], torch.full((4,), 1.0 if torch.det(a) > 0 else -1.0, dtype=F64))


def with_degenerate_uv_vertex():
    """The quad plus vertex 4 in one face (1, 4, 2) whose three uvs coincide."""
    pos, uvs, tri, normals = quad(lambda x, y: torch.stack([x, y]))
    pos = torch.cat([pos, t64(1.6, 0.5, 0.2)[None]])
    uvs = torch.cat([uvs, uvs[1][None]])
    uvs[2] = uvs[1]  # faces using vertices 1 and 2 together: (0, 1, 2) becomes degenerate as well
    normals = torch.cat([normals, unit(t64(0.1, 0.0, 1.0))[None]])
    return pos, uvs, torch.cat([tri, torch.tensor([[1, 4, 2]], dtype=torch.int32)]), normals


def test_a_vertex_with_only_degenerate_uv_faces_gets_a_zero_tangent_and_w_plus_one():
    pos, uvs, tri, normals = with_degenerate_uv_vertex()
    got = S.vertex_tangents(pos, uvs, tri, normals)
    assert torch.equal(got[4], t64(0, 0, 0, 1))
    assert torch.equal(got[1], t64(0, 0, 0, 1))  # vertex 1 is only in (0, 1, 2) and (1, 4, 2)
    # vertex 0: face (0, 2, 3) alone, uvs (0, 0), (1, 0), (0, 1) at (0, 0, 0), (1, 1, 0), (0, 1, 0):
    # dp/du = (1, 1, 0), dp/dv = (0, 1, 0), n x t = (-1, 1, 0) / sqrt 2, so w = +1
    r = 1 / math.sqrt(2)
    assert torch.allclose(got[0], t64(r, r, 0, 1), rtol=1e-15)
    # and perturb_normal makes no perturbation from a zero tangent
    assert torch.allclose(S.perturb_normal(normals[4], got[4], t64(0.2, 0.9, 0.8)), normals[4], rtol=1e-15)


def sphere_mesh(rings=8, segments=12, jitter=0.0, seed=0):
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
    pos, uv = torch.tensor(pos, dtype=F64), torch.tensor(uv, dtype=F64)
    if jitter:
        g = torch.Generator().manual_seed(seed)
        pos = pos + jitter * torch.randn(pos.shape, generator=g, dtype=F64)
        uv = uv + 0.2 * jitter * torch.randn(uv.shape, generator=g, dtype=F64)
    return pos, uv, torch.tensor(tri, dtype=torch.int64), unit(pos)


def height_field(seed, n=3):
    """A jittered (n+1)^2 grid with random heights, uvs about (x, y), normals about +z (not unit-exact)."""
    g = torch.Generator().manual_seed(seed)
    s = torch.linspace(0, 1, n + 1, dtype=F64)
    x, y = torch.meshgrid(s, s, indexing='ij')
    xy = torch.stack([x, y], -1).reshape(-1, 2)
    pos = torch.cat([xy + 0.05 * torch.randn(xy.shape, generator=g, dtype=F64),
                     0.3 * torch.rand(xy.shape[0], 1, generator=g, dtype=F64)], -1)
    uv = xy + 0.03 * torch.randn(xy.shape, generator=g, dtype=F64)
    normals = unit(t64(0, 0, 1) + 0.2 * torch.randn(pos.shape, generator=g, dtype=F64))
    idx = lambda i, j: i * (n + 1) + j
    tri = [[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)] for i in range(n) for j in range(n)]
    tri += [[idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)] for i in range(n) for j in range(n)]
    return pos, uv, torch.tensor(tri, dtype=torch.int32), normals


def test_sphere_tangents_follow_increasing_u_and_are_orthogonal_to_the_normals():
    pos, uv, tri, normals = sphere_mesh(24, 48)
    got = S.vertex_tangents(pos, uv, tri, normals)
    t = got[:, :3]
    assert torch.allclose((t * normals).sum(-1), torch.zeros(len(pos), dtype=F64), atol=1e-14)
    y = pos[:, 1]
    body = y.abs() < 0.99  # away from the poles, where u is degenerate
    dp_du = torch.stack([pos[:, 2], torch.zeros_like(y), -pos[:, 0]], -1)  # d/dphi of the parametrization
    cos = (t[body] * unit(dp_du[body])).sum(-1)
    assert cos.min() > 0.995  # a faceted sphere: the tangents average their faces'
    # v grows from the north pole downwards: dp/dv = -(n x t) there, a mirrored frame
    assert torch.equal(got[body, 3], torch.full((int(body.sum()),), -1.0, dtype=F64))


def test_vertex_tangents_are_bit_identical_on_1_and_4_threads():
    pos, uv, tri, normals = sphere_mesh(40, 80, jitter=0.01, seed=3)
    saved = torch.get_num_threads()
    runs = []
    try:
        for threads in (1, 4, 1):
            torch.set_num_threads(threads)
            inputs = [x.clone().requires_grad_(True) for x in (pos, uv, normals)]
            out = S.vertex_tangents(inputs[0], inputs[1], tri, inputs[2])
            weights = torch.linspace(-1, 1, out.numel(), dtype=F64).reshape(out.shape)
            grads = torch.autograd.grad((out * weights).sum(), inputs)
            runs.append([out] + list(grads))
    finally:
        torch.set_num_threads(saved)
    for run in runs[1:]:
        assert all(torch.equal(a, b) for a, b in zip(runs[0], run))


@pytest.mark.parametrize('mesh', ['random', 'mirrored', 'degenerate uv vertex'])
def test_vertex_tangent_gradients(mesh):
    if mesh == 'degenerate uv vertex':
        pos, uv, tri, normals = with_degenerate_uv_vertex()
        # uvs only where they do not touch a degenerate face (sign(det) jumps there)
        free = torch.tensor([0, 3])  # uv1 = uv2, so uv0 leaves (0, 1, 2) degenerate
        fn = lambda p, u_free, n: S.vertex_tangents(p, uv.index_copy(0, free, u_free), tri, n)
        assert gradients_match(fn, pos, uv[free], normals)
        return
    pos, uv, tri, normals = height_field(seed=1)
    if mesh == 'mirrored':
        uv = uv * t64(-1.0, 1.0)
    assert torch.equal(S.vertex_tangents(pos, uv, tri, normals)[:, 3], torch.full((16,), -1.0 if mesh == 'mirrored' else 1.0, dtype=F64))
    assert gradients_match(lambda p, u, n: S.vertex_tangents(p, u, tri, n), pos, uv, normals)


def test_perturb_normal_known_frames():
    n, frame = t64(0, 0, 1), t64(2, 0, 0.5, 1)  # the tangent is orthogonalized and normalized
    assert torch.allclose(S.perturb_normal(n, frame, t64(0.5, 0.5, 1.0)), n, rtol=1e-15)
    assert torch.allclose(S.perturb_normal(n, frame, t64(1.0, 0.5, 0.5)), t64(1, 0, 0), atol=1e-15)
    assert torch.allclose(S.perturb_normal(n, frame, t64(0.5, 1.0, 0.5)), t64(0, 1, 0), atol=1e-15)
    mirrored = t64(2, 0, 0.5, -1)
    assert torch.allclose(S.perturb_normal(n, mirrored, t64(0.5, 1.0, 0.5)), t64(0, -1, 0), atol=1e-15)
    assert torch.allclose(S.perturb_normal(n, frame, t64(0.75, 0.5, 0.75)), unit(t64(1, 0, 1)), rtol=1e-15)


@pytest.mark.parametrize('w', [1.0, -1.0])
def test_perturb_normal_gradients(w):
    g = torch.Generator().manual_seed(18)
    n = random_units(g, 3, 4)
    tangent = torch.cat([torch.randn(3, 4, 3, generator=g, dtype=F64), torch.full((3, 4, 1), w, dtype=F64)], -1)
    texel = torch.rand(3, 4, 3, generator=g, dtype=F64)
    assert gradients_match(S.perturb_normal, n, tangent, texel)
    assert gradients_match(S.reflect_view, random_units(g, 3, 4), n)


@pytest.mark.parametrize('kind', ['zero', 'parallel to the normal'])
def test_perturb_normal_with_a_degenerate_tangent_keeps_the_normal_and_finite_gradients(kind):
    g = torch.Generator().manual_seed(19)
    n = random_units(g, 5)
    xyz = torch.zeros(5, 3, dtype=F64) if kind == 'zero' else 0.7 * n
    tangent = torch.cat([xyz, torch.ones(5, 1, dtype=F64)], -1)
    texel = torch.rand(5, 3, generator=g, dtype=F64) * 0.5 + 0.5
    inputs = [x.clone().requires_grad_(True) for x in (n, tangent, texel)]
    out = S.perturb_normal(*inputs)
    out.sum().backward()
    assert all(torch.isfinite(x.grad).all() for x in inputs)
    assert torch.allclose(out.norm(dim=-1), torch.ones(5, dtype=F64), rtol=1e-14)
    if kind == 'zero':
        assert torch.allclose(out, n, rtol=1e-14, atol=1e-15)
        # the direction of a zero tangent is undefined (no derivative w.r.t. it); the others have one
        assert gradients_match(lambda n_, texel_: S.perturb_normal(n_, tangent, texel_), n, texel)
    else:
        # t = normalize(rounding residue): a direction at random, tiny or unit; n' stays a unit vector
        # within 90 degrees of n (m.z > 0)
        assert ((out * n).sum(-1) > 0).all()


def test_reflect_view_mirrors_about_the_normal():
    n = unit(t64(0.0, 1.0, 1.0))
    assert torch.allclose(S.reflect_view(n, n), n, rtol=1e-15)
    v = unit(t64(0.3, 0.9, -0.1))
    r = S.reflect_view(v, n)
    assert torch.allclose(r + v, 2 * (n @ v) * n, rtol=1e-15) and r.norm().item() == pytest.approx(1.0, rel=1e-15)


# ----------------------------------------------------------------------------
# Bad input

V3, V1 = t64(0, 0, 1), t64(0.5)
TRI = torch.tensor([[0, 1, 2]])
P3 = torch.rand(3, 3, dtype=F64)

BAD = [
    (lambda: S.lambert([1.0, 1.0, 1.0], V3, V3), TypeError, "lambert: 'albedo' must be a torch.Tensor"),
    (lambda: S.lambert(V3, V3.int(), V3), TypeError, "lambert: 'normal' must be float32 or float64"),
    (lambda: S.lambert(V3, V3, V3.float()), TypeError, "'light_dir' is torch.float32 but 'albedo' is torch.float64"),
    (lambda: S.lambert(V3, t64(0, 1), V3), ValueError, "lambert: 'normal' must have shape [..., 3], got [2]"),
    (lambda: S.lambert(V3, torch.zeros(4, 3, dtype=F64), torch.zeros(5, 3, dtype=F64)), ValueError,
     "do not broadcast"),
    (lambda: S.cook_torrance(V3, V1, V3, V3, V3, V3), ValueError, "'roughness' must have shape [..., 1]"),
    (lambda: S.blinn_phong(V3, V3, t64(1, 2), V3, V3, V3), ValueError, "'shininess' must have shape [..., 1]"),
    (lambda: S.perturb_normal(V3, V3, V3), ValueError, "perturb_normal: 'tangent' must have shape [..., 4]"),
    (lambda: S.point_light(V3, V3, t64(1.0)), ValueError, "point_light: 'position' must have shape [..., 3]"),
    (lambda: S.sh_irradiance(V3, torch.zeros(4, 3, dtype=F64)), ValueError, "'sh' must have shape [9, C]"),
    (lambda: S.sh_diffuse(t64(1, 1), V3, torch.zeros(9, 3, dtype=F64)), ValueError, "'albedo' has 2 channels"),
    (lambda: S.srgb_to_linear(torch.tensor([1, 2])), TypeError, "srgb_to_linear: 'x' must be float32 or float64"),
    (lambda: S.ggx_distribution(V1, 0.5), TypeError, "ggx_distribution: 'alpha' must be a torch.Tensor"),
    (lambda: S.environment_light(torch.zeros(6, 2, 3, 1, dtype=F64), V3), ValueError, "'cube_map' must have shape"),
    (lambda: S.environment_light(torch.zeros(2, 6, 2, 2, 1, dtype=F64), torch.zeros(3, 3, dtype=F64)), ValueError,
     "needs 'direction' of shape [2, ..., 3]"),
    (lambda: S.environment_light(torch.zeros(6, 2, 2, 1, dtype=F64), torch.zeros(4, 3, dtype=F64),
                                 mip_level_bias=torch.zeros(5, dtype=F64)), ValueError,
     "'mip_level_bias' must have shape [4]"),
    (lambda: S.vertex_tangents(P3, P3[:, :2], TRI, P3[:2]), ValueError, "'normals' must have shape [V, 3] with V = 3"),
    (lambda: S.vertex_tangents(P3, P3, TRI, P3), ValueError, "'uvs' must have shape [V, 2] with V = 3"),
    (lambda: S.vertex_tangents(P3, P3[:, :2], TRI.double(), P3), TypeError, "'triangles' must have an integer dtype"),
    (lambda: S.vertex_tangents(P3, P3[:, :2], TRI[:, :2], P3), ValueError, "'triangles' must have shape [M, 3]"),
    (lambda: S.vertex_tangents(P3, P3[:, :2], TRI + 1, P3), IndexError, "vertex index 3, outside [0, 3)"),
    (lambda: S.vertex_tangents(P3, P3[:, :2], TRI - 1, P3), IndexError, "vertex index -1, outside [0, 3)"),
    (lambda: S.vertex_tangents(P3, P3[:, :2].float(), TRI, P3), TypeError, "'uvs' is torch.float32"),
]


@pytest.mark.parametrize('index', range(len(BAD)))
def test_bad_input_raises_naming_the_argument(index):
    call, error, message = BAD[index]
    with pytest.raises(error) as info:
        call()
    assert message in str(info.value)
