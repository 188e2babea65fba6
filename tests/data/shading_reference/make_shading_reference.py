#!/usr/bin/env python3
"""Writes shading_reference.txt: known values of the shading functions
(docs/shading.md), evaluated independently of both implementations (plain
Python floats, i.e. IEEE float64, with the math module; one scalar formula per
component, written from the published formulas):

  sRGB: IEC 61966-2-1.  GGX: Walter et al. 2007, eq. 33.  Smith height-
  correlated visibility: Heitz 2014, eq. 99, over 4 n.l n.v.  Fresnel: Schlick
  1994.  Cook-Torrance: glTF 2.0 specification, appendix B.  SH: Ramamoorthi &
  Hanrahan 2001, eqs. 3, 12.

Each line: a function name, then its inputs, then its outputs, all as
17-significant-digit decimals, separated by single spaces; the arity of each
function is listed in README.md. Run: python3 make_shading_reference.py > shading_reference.txt
"""
import math
import random

PI = math.pi


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def unit(a):
    n = math.sqrt(dot(a, a))
    return [x / n for x in a]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def srgb_to_linear(x):
    if x <= 0.04045:
        return x / 12.92
    return ((x + 0.055) / 1.055) ** 2.4


def linear_to_srgb(x):
    if x <= 0.0031308:
        return 12.92 * x
    return 1.055 * x ** (1.0 / 2.4) - 0.055


def lambert(albedo, n, l):
    c = max(dot(n, l), 0.0)
    return [a * c / PI for a in albedo]


def blinn_phong(albedo, specular, shininess, n, l, v):
    h = unit([l[i] + v[i] for i in range(3)])
    nl = dot(n, l)
    spec = max(dot(n, h), 0.0) ** shininess if nl > 0 else 0.0
    return [albedo[i] * max(nl, 0.0) / PI + specular[i] * spec for i in range(3)]


def ggx_distribution(nh, alpha):
    a2 = alpha * alpha
    d = nh * nh * (a2 - 1.0) + 1.0
    return a2 / (PI * d * d)


def smith_ggx_correlated(nv, nl, alpha):
    a2 = alpha * alpha
    gv = nl * math.sqrt(nv * nv * (1.0 - a2) + a2)
    gl = nv * math.sqrt(nl * nl * (1.0 - a2) + a2)
    return 0.5 / (gv + gl)


def fresnel_schlick(c, f0):
    return [f + (1.0 - f) * (1.0 - c) ** 5 for f in f0]


def cook_torrance(base, metallic, roughness, n, l, v):
    r = min(max(roughness, 0.03), 1.0)
    alpha = r * r
    h = unit([l[i] + v[i] for i in range(3)])
    nl = max(dot(n, l), 0.0)
    nv = max(dot(n, v), 1e-4)
    nh = max(dot(n, h), 0.0)
    vh = max(dot(v, h), 0.0)
    d = ggx_distribution(nh, alpha)
    vis = smith_ggx_correlated(nv, nl, alpha)
    out = []
    for i in range(3):
        f0 = 0.04 * (1.0 - metallic) + base[i] * metallic
        f = f0 + (1.0 - f0) * (1.0 - vh) ** 5
        diffuse = (1.0 - f) * (1.0 - metallic) * base[i] / PI
        out.append((diffuse + f * d * vis) * nl)
    return out


def point_light(light_pos, intensity, p):
    d = [light_pos[i] - p[i] for i in range(3)]
    d2 = dot(d, d)
    return unit(d) + [x / d2 for x in intensity]


def sh_basis(d):
    x, y, z = d
    c0 = math.sqrt(1.0 / (4.0 * PI))
    c1 = math.sqrt(3.0 / (4.0 * PI))
    c2 = math.sqrt(15.0 / (4.0 * PI))
    c20 = math.sqrt(5.0 / (16.0 * PI))
    c22 = math.sqrt(15.0 / (16.0 * PI))
    return [c0, c1 * y, c1 * z, c1 * x, c2 * x * y, c2 * y * z, c20 * (3.0 * z * z - 1.0), c2 * x * z,
            c22 * (x * x - y * y)]


def sh_irradiance(n, sh):  # sh: 9 rows of 3
    a = [PI] + [2.0 * PI / 3.0] * 3 + [PI / 4.0] * 5
    y = sh_basis(n)
    return [sum(a[k] * sh[k][c] * y[k] for k in range(9)) for c in range(3)]


def perturb_normal(n, tangent, texel):
    m = [2.0 * t - 1.0 for t in texel]
    t3 = tangent[:3]
    nt = dot(n, t3)
    t = unit([t3[i] - n[i] * nt for i in range(3)])
    b = [tangent[3] * x for x in cross(n, t)]
    return unit([t[i] * m[0] + b[i] * m[1] + n[i] * m[2] for i in range(3)])


def rand_unit(rng):
    while True:
        v = [rng.uniform(-1, 1) for _ in range(3)]
        if 0.01 < dot(v, v) <= 1.0:
            return unit(v)


def upper_unit(rng, n):  # a random unit vector with n . v > 0.05
    while True:
        v = rand_unit(rng)
        if dot(v, n) > 0.05:
            return v


def fmt(values):
    return ' '.join('%.17g' % v for v in values)


def main():
    rng = random.Random(20261128)
    rows = []
    for x in [-0.1, 0.0, 0.001, 0.04045, 0.0405, 0.2, 0.5, 0.73, 1.0, 1.3]:
        rows.append(('srgb_to_linear', [x], [srgb_to_linear(x)]))
    for x in [-0.01, 0.0, 0.0001, 0.0031308, 0.0032, 0.05, 0.21404114048223255, 0.5, 1.0, 2.0]:
        rows.append(('linear_to_srgb', [x], [linear_to_srgb(x)]))
    for _ in range(8):
        n = rand_unit(rng)
        l = rand_unit(rng)  # includes lights below the horizon
        v = upper_unit(rng, n)
        albedo = [rng.uniform(0, 1) for _ in range(3)]
        specular = [rng.uniform(0, 1) for _ in range(3)]
        shininess = rng.uniform(1, 64)
        rows.append(('lambert', albedo + n + l, lambert(albedo, n, l)))
        rows.append(('blinn_phong', albedo + specular + [shininess] + n + l + v,
                      blinn_phong(albedo, specular, shininess, n, l, v)))
    for nh, alpha in [(1.0, 0.5), (0.9, 0.3), (0.5, 0.8), (0.0, 0.2), (0.99, 0.0009), (0.7, 1.0)]:
        rows.append(('ggx_distribution', [nh, alpha], [ggx_distribution(nh, alpha)]))
    for nv, nl, alpha in [(1.0, 1.0, 0.5), (0.3, 0.8, 0.2), (1e-4, 0.5, 0.7), (0.9, 0.01, 0.05), (0.5, 0.5, 1.0)]:
        rows.append(('smith_ggx_correlated', [nv, nl, alpha], [smith_ggx_correlated(nv, nl, alpha)]))
    for c in [0.0, 0.2, 0.7, 1.0]:
        f0 = [rng.uniform(0, 1) for _ in range(3)]
        rows.append(('fresnel_schlick', [c] + f0, fresnel_schlick(c, f0)))
    for metallic, roughness in [(0.0, 0.5), (1.0, 0.3), (0.4, 0.8), (0.0, 0.01), (0.7, 1.0), (0.2, 0.03),
                                (1.0, 0.1), (0.5, 0.6)]:
        n = rand_unit(rng)
        l = upper_unit(rng, n) if metallic != 0.5 else rand_unit(rng)  # one light may be below the horizon
        v = upper_unit(rng, n)
        base = [rng.uniform(0, 1) for _ in range(3)]
        rows.append(('cook_torrance', base + [metallic, roughness] + n + l + v,
                     cook_torrance(base, metallic, roughness, n, l, v)))
    for _ in range(4):
        lp = [rng.uniform(-3, 3) for _ in range(3)]
        p = [rng.uniform(-1, 1) for _ in range(3)]
        intensity = [rng.uniform(0, 10) for _ in range(3)]
        rows.append(('point_light', lp + intensity + p, point_light(lp, intensity, p)))
    for _ in range(4):
        d = rand_unit(rng)
        rows.append(('sh_basis', d, sh_basis(d)))
    for _ in range(4):
        n = rand_unit(rng)
        sh = [[rng.uniform(-1, 1) for _ in range(3)] for _ in range(9)]
        rows.append(('sh_irradiance', n + [x for row in sh for x in row], sh_irradiance(n, sh)))
    for w in [1.0, -1.0, 1.0, -1.0]:
        n = rand_unit(rng)
        t = [rng.uniform(-1, 1) for _ in range(3)] + [w]
        texel = [rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(0.5, 1)]
        rows.append(('perturb_normal', n + t + texel, perturb_normal(n, t, texel)))
    for name, inputs, outputs in rows:
        print(name, fmt(inputs), fmt(outputs))


if __name__ == '__main__':
    main()
