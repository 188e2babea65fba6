"""gradraster.losses: PyTorch3D's mesh losses, vertex normals and the large-steps
reparametrization, checked against loop implementations written here from
the definitions, against values worked out by hand, and by gradcheck."""
import math

import pytest
import torch

from gradraster import losses

F64 = torch.float64


# ----------------------------------------------------------------------------
# Meshes


def outward(verts, faces):
    """faces reordered so each one's (p1 - p0) x (p2 - p0) points away from the centroid of verts."""
    centre = verts.mean(0)
    out = []
    for f in faces.tolist():
        p = verts[f]
        n = torch.cross(p[1] - p[0], p[2] - p[0], dim=0)
        out.append(f if torch.dot(n, p.mean(0) - centre) > 0 else [f[0], f[2], f[1]])
    return torch.tensor(out, dtype=torch.int64)


def tetrahedron():
    """Regular, edge length 2 sqrt(2), faces outward."""
    v = torch.tensor([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=F64)
    return v, outward(v, torch.tensor([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]))


def cube():
    """Unit cube, each square split by a diagonal: 12 sides of length 1, 6 diagonals, faces outward."""
    v = torch.tensor([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=F64)
    quads = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]]
    tris = [t for a, b, c, d in quads for t in ([a, b, c], [a, c, d])]
    return v, outward(v, torch.tensor(tris))


def grid(n, bump=0.0, jitter=0.0, seed=0):
    """(n+1)^2 vertices on [0, 1]^2 in the plane z = bump * exp(-8 |xy - centre|^2),
    each square split along the same diagonal, faces counter-clockwise seen from +z."""
    g = torch.Generator().manual_seed(seed)
    s = torch.linspace(0, 1, n + 1, dtype=F64)
    x, y = torch.meshgrid(s, s, indexing='ij')
    z = bump * torch.exp(-8 * ((x - 0.5) ** 2 + (y - 0.5) ** 2))
    v = torch.stack([x, y, z], -1).reshape(-1, 3)
    v = v + jitter * (torch.rand(v.shape, generator=g, dtype=F64) - 0.5)
    idx = lambda i, j: i * (n + 1) + j
    faces = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            faces += [[a, b, c], [a, c, d]]
    return v, torch.tensor(faces)


def random_mesh(seed, n=3):
    """A grid with random heights and jittered vertices: no symmetry, no flat pair."""
    v, f = grid(n, jitter=0.15, seed=seed)
    g = torch.Generator().manual_seed(seed + 100)
    v[:, 2] = torch.rand(v.shape[0], generator=g, dtype=F64) * 0.6
    return v, f


def uv_sphere(radius, rings=24, segments=48):
    v = [[0.0, 0.0, radius]]
    for r in range(1, rings):
        t = math.pi * r / rings
        for s in range(segments):
            p = 2 * math.pi * s / segments
            v.append([radius * math.sin(t) * math.cos(p), radius * math.sin(t) * math.sin(p), radius * math.cos(t)])
    v.append([0.0, 0.0, -radius])
    ring = lambda r, s: 1 + (r - 1) * segments + s % segments
    f = [[0, ring(1, s), ring(1, s + 1)] for s in range(segments)]
    for r in range(1, rings - 1):
        for s in range(segments):
            a, b, c, d = ring(r, s), ring(r + 1, s), ring(r + 1, s + 1), ring(r, s + 1)
            f += [[a, b, c], [a, c, d]]
    f += [[len(v) - 1, ring(rings - 1, s + 1), ring(rings - 1, s)] for s in range(segments)]
    v = torch.tensor(v, dtype=F64)
    return v, outward(v, torch.tensor(f))


def with_zero_area_face(seed=1):
    """A random mesh plus a new vertex m on one of its border edges (a, b), 3/10 of
    the way, and the face (a, b, m): collinear, zero area, on an edge shared with
    the mesh. (Not the midpoint: there the cot Laplacian of m, (a + b) / 2 - m, is 0,
    where |r| has a kink.)"""
    v, f = random_mesh(seed)
    a, b = f[0, 0].item(), f[0, 1].item()
    v = torch.cat([v, (0.7 * v[a] + 0.3 * v[b])[None]])
    return v, torch.cat([f, torch.tensor([[a, b, v.shape[0] - 1]])])


def with_one_neighbour_vertex(seed=2):
    """A random mesh plus a vertex w and the face (a, w, w): w's only neighbour is a."""
    v, f = random_mesh(seed)
    v = torch.cat([v, torch.tensor([[0.3, 1.4, 0.2]], dtype=F64)])
    w = v.shape[0] - 1
    return v, torch.cat([f, torch.tensor([[4, w, w]])])


def with_isolated_vertex(seed=3):
    v, f = random_mesh(seed)
    return torch.cat([v, torch.tensor([[0.4, -0.7, 0.9]], dtype=F64)]), f


def non_manifold(seed=4):
    """Three triangles on the edge (0, 1) (a fan of fins), plus one more on each fin."""
    g = torch.Generator().manual_seed(seed)
    v = torch.tensor([[0, 0, 0], [1, 0, 0], [0.5, 1, 0.1], [0.4, -0.7, 0.6], [0.6, -0.5, -0.8],
                      [1.2, 0.9, 0.4], [1.1, -0.6, 0.9]], dtype=F64)
    v = v + 0.05 * torch.rand(v.shape, generator=g, dtype=F64)
    return v, torch.tensor([[0, 1, 2], [1, 0, 3], [0, 4, 1], [1, 5, 2], [1, 3, 6]])


def with_sliver_face():
    """with_zero_area_face with m lifted 1e-3 off the line: thin, but every function is smooth there."""
    v, f = with_zero_area_face()
    v[-1, 2] += 1e-3
    return v, f


HARD_CASES = {'zero-area face': with_zero_area_face, 'sliver face': with_sliver_face, 'vertex with one neighbour': with_one_neighbour_vertex,
              'isolated vertex': with_isolated_vertex, 'edge of three faces': non_manifold}


# ----------------------------------------------------------------------------
# References: loops over the definitions, in float64


def distinct_edges(faces):
    return sorted({tuple(sorted((f[k], f[(k + 1) % 3]))) for f in faces.tolist() for k in range(3)})


def ref_edge_loss(v, faces, target):
    e = distinct_edges(faces)
    return sum((torch.linalg.norm(v[i] - v[j]).item() - target) ** 2 for i, j in e) / len(e)


def ref_uniform_residuals(v, faces):
    """r_i = mean of the edge neighbours - v_i (a self edge (i, i) lists i twice), -v_i when isolated."""
    nb = {i: [] for i in range(v.shape[0])}
    for i, j in distinct_edges(faces):
        nb[i].append(j)
        nb[j].append(i)
    return [sum(v[j] for j in nb[i]) / len(nb[i]) - v[i] if nb[i] else -v[i] for i in range(v.shape[0])]


def corner_cot(p, k):
    """cot of the angle at corner k of triangle p [3, 3], as cos / sin from the two side vectors."""
    u, w = p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]
    return (torch.dot(u, w) / torch.linalg.norm(torch.cross(u, w, dim=0))).item()


def ref_cot_weights(v, faces):
    """w[(i, j)] = sum over the faces with side (i, j) of the cot of the angle opposite it; A[i] = area at i."""
    w, area = {}, [0.0] * v.shape[0]
    for f in faces.tolist():
        p = v[f]
        for k in range(3):
            i, j = f[(k + 1) % 3], f[(k + 2) % 3]
            for key in ((i, j), (j, i)):
                w[key] = w.get(key, 0.0) + corner_cot(p, k)
            area[f[k]] += 0.5 * torch.linalg.norm(torch.cross(p[1] - p[0], p[2] - p[0], dim=0)).item()
    return w, area


def ref_cot_residuals(v, faces, curvature):
    w, area = ref_cot_weights(v, faces)
    out = []
    for i in range(v.shape[0]):
        terms = [(wij, j) for (a, j), wij in w.items() if a == i]
        total = sum(wij for wij, _ in terms)
        if curvature:
            s = sum((wij * (v[j] - v[i]) for wij, j in terms), torch.zeros(3, dtype=F64))
            out.append(s / (4 * area[i]) if area[i] > 0 else torch.zeros(3, dtype=F64))
        else:
            s = sum((wij * v[j] for wij, j in terms), torch.zeros(3, dtype=F64))
            out.append(s / total - v[i] if total > 0 else s * total - v[i])
    return out


def ref_laplacian_smoothing(v, faces, method):
    r = {'uniform': lambda: ref_uniform_residuals(v, faces), 'cot': lambda: ref_cot_residuals(v, faces, False),
         'cotcurv': lambda: ref_cot_residuals(v, faces, True)}[method]()
    return sum(torch.linalg.norm(x).item() for x in r) / len(r)


def ref_normal_consistency(v, faces):
    """For each edge (a, b), a < b, and each pair of faces on it with third vertices w0, w1:
    1 - cos((b - a) x (w0 - a), -(b - a) x (w1 - a)); the mean of all."""
    third = {}
    for f in faces.tolist():
        for k in range(3):
            e = tuple(sorted((f[(k + 1) % 3], f[(k + 2) % 3])))
            third.setdefault(e, []).append(f[k])
    terms = []
    for (a, b), ws in third.items():
        e = v[b] - v[a]
        for p in range(len(ws)):
            for q in range(p + 1, len(ws)):
                n0 = torch.cross(e, v[ws[p]] - v[a], dim=0)
                n1 = -torch.cross(e, v[ws[q]] - v[a], dim=0)
                terms.append(1 - (torch.dot(n0, n1) / (torch.linalg.norm(n0) * torch.linalg.norm(n1))).item())
    return sum(terms) / len(terms)


def face_normal_consistency(v, faces):
    """For a consistently oriented closed or open manifold mesh: the mean over edges of two
    faces of 1 - (unit normal of one face) . (unit normal of the other)."""
    faces_of = {}
    for n, f in enumerate(faces.tolist()):
        for k in range(3):
            faces_of.setdefault(tuple(sorted((f[k], f[(k + 1) % 3]))), []).append(n)
    p = v[faces]
    normal = torch.nn.functional.normalize(torch.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], dim=1), dim=1)
    terms = [1 - torch.dot(normal[a], normal[b]).item() for fs in faces_of.values() if len(fs) == 2 for a, b in [fs]]
    return sum(terms) / len(terms)


def ref_vertex_normals(v, faces):
    s = torch.zeros_like(v)
    for f in faces.tolist():
        p = v[f]
        for i in f:
            s[i] += torch.cross(p[1] - p[0], p[2] - p[0], dim=0)
    return torch.stack([x / torch.linalg.norm(x) if torch.linalg.norm(x) > 0 else x for x in s])


NAMED_MESHES = {'tetrahedron': tetrahedron, 'cube': cube, 'plane with a bump': lambda: grid(4, bump=0.4),
                'random mesh': lambda: random_mesh(7), 'non-manifold fins': non_manifold,
                'mesh with an isolated vertex': with_isolated_vertex}


# ----------------------------------------------------------------------------
# Values against the references and by hand


@pytest.mark.parametrize('name', NAMED_MESHES)
@pytest.mark.parametrize('target', [0.0, 0.7])
def test_edge_loss_is_the_mean_squared_deviation_of_the_distinct_edge_lengths(name, target):
    v, f = NAMED_MESHES[name]()
    assert losses.mesh_edge_loss(v, f, target).item() == pytest.approx(ref_edge_loss(v, f, target), rel=1e-12)


def test_edge_loss_by_hand_on_the_cube_and_the_tetrahedron():
    v, f = cube()  # 12 sides of length 1 and 6 diagonals of length sqrt(2)
    assert losses.mesh_edge_loss(v, f).item() == pytest.approx((12 * 1 + 6 * 2) / 18, rel=1e-14)
    v, f = tetrahedron()  # all 6 edges 2 sqrt(2): zero at that target
    assert losses.mesh_edge_loss(v, f, target_length=2 * math.sqrt(2)).item() == pytest.approx(0, abs=1e-14)
    assert losses.mesh_edge_loss(v, f, target_length=1.0).item() == pytest.approx((2 * math.sqrt(2) - 1) ** 2)


@pytest.mark.parametrize('name', NAMED_MESHES)
@pytest.mark.parametrize('method', ['uniform', 'cot', 'cotcurv'])
def test_laplacian_smoothing_matches_the_loop_over_its_definition(name, method):
    v, f = NAMED_MESHES[name]()
    got = losses.mesh_laplacian_smoothing(v, f, method).item()
    assert got == pytest.approx(ref_laplacian_smoothing(v, f, method), rel=1e-10)
    assert losses.mesh_laplacian_smoothing(v, f, method, differentiable_weights=True).item() == got


def test_uniform_laplacian_by_hand_on_a_square_fan_with_a_raised_centre():
    # centre (0, 0, h) with ring (+-1, 0, 0), (0, +-1, 0): the centre's residual is (0, 0, -h),
    # each ring vertex's (-1, 0, h / 3) up to the direction in the plane.
    h = 0.6
    v = torch.tensor([[0, 0, h], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], dtype=F64)
    f = torch.tensor([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    want = (h + 4 * math.sqrt(1 + h * h / 9)) / 5
    assert losses.mesh_laplacian_smoothing(v, f, 'uniform').item() == pytest.approx(want, rel=1e-14)


@pytest.mark.parametrize('method', ['uniform', 'cot'])
def test_the_laplacian_of_a_flat_regular_grid_is_zero_inside_so_only_the_border_counts(method):
    v, f = grid(5)
    r = ref_uniform_residuals(v, f) if method == 'uniform' else ref_cot_residuals(v, f, False)
    inside = [i for i in range(v.shape[0]) if 0 < v[i, 0] < 1 and 0 < v[i, 1] < 1]
    assert len(inside) == 16 and all(torch.linalg.norm(r[i]).item() < 1e-14 for i in inside)
    border = sum(torch.linalg.norm(r[i]).item() for i in range(v.shape[0]) if i not in inside)
    got = losses.mesh_laplacian_smoothing(v, f, method).item()
    assert got == pytest.approx(border / v.shape[0], rel=1e-12) and got > 0


def test_cot_curvature_on_a_sphere_is_about_a_third_of_the_mean_curvature():
    # sum_j (cot a + cot b)(v_j - v_i) ~ 4 A_voronoi H n, A_voronoi ~ A_i / 3, so |r_i| ~ H / 3 = 1 / (3 R).
    for radius in (0.5, 2.0):
        v, f = uv_sphere(radius)
        got = losses.mesh_laplacian_smoothing(v, f, 'cotcurv').item()
        assert got == pytest.approx(1 / (3 * radius), rel=0.03)


@pytest.mark.parametrize('name', ['tetrahedron', 'cube', 'plane with a bump', 'random mesh'])
def test_normal_consistency_is_one_minus_the_cosine_of_neighbouring_face_normals(name):
    v, f = NAMED_MESHES[name]()
    got = losses.mesh_normal_consistency(v, f).item()
    assert got == pytest.approx(face_normal_consistency(v, f), rel=1e-12)
    assert got == pytest.approx(ref_normal_consistency(v, f), rel=1e-12)


def test_normal_consistency_by_hand_flat_plane_cube_and_tetrahedron():
    v, f = grid(4)
    assert losses.mesh_normal_consistency(v, f).item() == pytest.approx(0, abs=1e-15)
    v, f = cube()  # 12 right-angle edges (1 each) and 6 flat diagonals (0)
    assert losses.mesh_normal_consistency(v, f).item() == pytest.approx(12 / 18, rel=1e-14)
    v, f = tetrahedron()  # face normals at cos = -1/3 on all 6 edges
    assert losses.mesh_normal_consistency(v, f).item() == pytest.approx(4 / 3, rel=1e-14)


def test_normal_consistency_does_not_depend_on_face_orientation():
    v, f = random_mesh(5)
    flipped = f.clone()
    flipped[::3] = f[::3][:, [0, 2, 1]]
    assert losses.mesh_normal_consistency(v, flipped).item() == pytest.approx(
        losses.mesh_normal_consistency(v, f).item(), rel=1e-14)


def test_normal_consistency_counts_every_pair_of_faces_on_an_edge_once():
    v, f = non_manifold()  # edge (0, 1): 3 faces, 3 pairs; edges (1, 2), (1, 3): 2 faces, 1 pair each
    assert losses.mesh_normal_consistency(v, f).item() == pytest.approx(ref_normal_consistency(v, f), rel=1e-12)
    # Four flat fins at right angles on one edge: pairs at 90 degrees give 1, opposite fins 0 or 2.
    v = torch.tensor([[0, 0, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], dtype=F64)
    f = torch.tensor([[0, 1, 2], [0, 1, 3], [0, 1, 4], [0, 1, 5]])
    # n(w) = e x w: pairs of fins at 90 degrees fold (1), opposite fins lie flat (0): 4 of 6 pairs give 1.
    assert losses.mesh_normal_consistency(v, f).item() == pytest.approx(4 / 6, rel=1e-14)


@pytest.mark.parametrize('name', NAMED_MESHES)
def test_vertex_normals_are_the_normalized_sums_of_face_cross_products(name):
    v, f = NAMED_MESHES[name]()
    torch.testing.assert_close(losses.vertex_normals(v, f), ref_vertex_normals(v, f), rtol=1e-12, atol=1e-14)


def test_vertex_normals_point_out_of_a_sphere_and_up_from_a_counter_clockwise_plane():
    v, f = uv_sphere(1.5)
    n = losses.vertex_normals(v, f)
    assert (n * v / 1.5).sum(1).min() > 0.99
    v, f = grid(3)
    torch.testing.assert_close(losses.vertex_normals(v, f), torch.tensor([[0, 0, 1.0]], dtype=F64).expand(16, 3))


# ----------------------------------------------------------------------------
# Hard cases: values


def test_a_zero_area_face_gives_finite_losses_and_gradients_and_normal_consistency_terms_of_one():
    v, f = with_zero_area_face()
    v.requires_grad_()
    for loss in (losses.mesh_edge_loss(v, f, 0.3), losses.mesh_normal_consistency(v, f),
                 losses.vertex_normals(v, f).sum(),
                 *(losses.mesh_laplacian_smoothing(v, f, m, d) for m in ('uniform', 'cot', 'cotcurv')
                   for d in (False, True))):
        (g,) = torch.autograd.grad(loss, v)
        assert torch.isfinite(loss) and torch.isfinite(g).all()
    # The degenerate face's normal is 0, so its one pair (on the mesh's border edge (a, b)) counts 1 - 0.
    base_v, base_f = random_mesh(1)
    pairs = sum(1 for n in count_faces_per_edge(base_f).values() if n == 2)
    base = losses.mesh_normal_consistency(base_v, base_f).item() * pairs
    assert count_faces_per_edge(f)[tuple(sorted(f[-1, :2].tolist()))] == 2
    # (m is collinear only up to rounding: n ~ 1e-17, clamped to eps = 1e-8, cos ~ 1e-9)
    assert losses.mesh_normal_consistency(v, f).item() == pytest.approx((base + 1) / (pairs + 1), abs=1e-8)


def count_faces_per_edge(faces):
    count = {}
    for f in faces.tolist():
        for k in range(3):
            e = tuple(sorted((f[k], f[(k + 1) % 3])))
            count[e] = count.get(e, 0) + 1
    return count


def test_a_vertex_with_one_neighbour_is_pulled_towards_it_by_the_uniform_laplacian():
    v, f = with_one_neighbour_vertex()
    w = v.shape[0] - 1
    # w's edges: (4, w) and the side (w, w), which PyTorch3D keeps and which lists w as its own neighbour twice.
    r = ref_uniform_residuals(v, f)[w]
    torch.testing.assert_close(r, (v[4] + 2 * v[w]) / 3 - v[w])
    assert losses.mesh_laplacian_smoothing(v, f).item() == pytest.approx(ref_laplacian_smoothing(v, f, 'uniform'))


def test_an_isolated_vertex_counts_its_distance_to_the_origin_in_uniform_and_cot_and_nothing_in_cotcurv():
    v, f = with_isolated_vertex()
    n = v.shape[0]
    for method, extra in (('uniform', v[-1].norm()), ('cot', v[-1].norm()), ('cotcurv', 0.0)):
        with_it = losses.mesh_laplacian_smoothing(v, f, method).item() * n
        without = losses.mesh_laplacian_smoothing(v[:-1], f, method).item() * (n - 1)
        assert with_it == pytest.approx(without + float(extra), rel=1e-12)
    assert losses.vertex_normals(v, f)[-1].abs().max() == 0


def test_empty_meshes_give_zero_with_a_zero_gradient():
    v = torch.rand(4, 3, dtype=F64, requires_grad=True)
    for loss in (losses.mesh_edge_loss(v, torch.zeros(0, 3, dtype=torch.int64)),
                 losses.mesh_laplacian_smoothing(v, torch.zeros(0, 3, dtype=torch.int64), 'cot'),
                 losses.mesh_normal_consistency(v, torch.tensor([[0, 1, 2]]))):  # no shared edge
        assert loss.item() == 0 and loss.dtype == F64
        assert torch.autograd.grad(loss, v)[0].abs().max() == 0


# ----------------------------------------------------------------------------
# Gradients


def gradcheck(fn, v):
    v = v.detach().clone().requires_grad_()
    assert torch.autograd.gradcheck(fn, (v,), eps=1e-6, atol=1e-6, rtol=1e-4)


GRAD_MESHES = {'random mesh 1': lambda: random_mesh(11), 'random mesh 2': lambda: random_mesh(12, n=2),
               'tetrahedron': lambda: (tetrahedron()[0] + 0.1 * torch.rand(4, 3, dtype=F64), tetrahedron()[1]),
               **HARD_CASES}

@pytest.mark.parametrize('name', GRAD_MESHES)
@pytest.mark.parametrize('target', [0.0, 0.5])
def test_edge_loss_passes_gradcheck(name, target):
    v, f = GRAD_MESHES[name]()
    gradcheck(lambda x: losses.mesh_edge_loss(x, f, target), v)


# At a collinear zero-area face (a, b, m) the cotangent weights reproduce m from a and b (linear
# precision), so m's cot and cotcurv residuals are 0 and |r_m| sits at its kink, where no gradient
# exists: those two are checked on the sliver face (and finite at the zero-area one, above).
KINKS = {('cot', 'zero-area face'), ('cotcurv', 'zero-area face')}


@pytest.mark.parametrize('method,name', [(m, n) for m in ('uniform', 'cot', 'cotcurv') for n in GRAD_MESHES
                                         if (m, n) not in KINKS])
def test_laplacian_smoothing_with_weights_held_constant_passes_gradcheck(method, name):
    # The default, as PyTorch3D: the gradient of the loss with the weights frozen at the current positions.
    v, f = GRAD_MESHES[name]()
    frozen = v.detach().clone()
    gradcheck(lambda x: losses._laplacian_smoothing(x, f, method, frozen), v)
    x = v.clone().requires_grad_()
    y = v.clone().requires_grad_()
    (gx,) = torch.autograd.grad(losses.mesh_laplacian_smoothing(x, f, method), x)
    (gy,) = torch.autograd.grad(losses._laplacian_smoothing(y, f, method, frozen), y)
    assert torch.equal(gx, gy)


@pytest.mark.parametrize('method,name', [(m, n) for m in ('cot', 'cotcurv') for n in GRAD_MESHES if (m, n) not in KINKS])
def test_laplacian_smoothing_with_differentiable_weights_passes_gradcheck(method, name):
    v, f = GRAD_MESHES[name]()
    gradcheck(lambda x: losses.mesh_laplacian_smoothing(x, f, method, differentiable_weights=True), v)


@pytest.mark.parametrize('name', [n for n in GRAD_MESHES if n != 'zero-area face'])
def test_normal_consistency_passes_gradcheck(name):
    # (At the zero-area face itself the loss jumps: its normal has no direction. Tested finite above.)
    v, f = GRAD_MESHES[name]()
    gradcheck(lambda x: losses.mesh_normal_consistency(x, f), v)


@pytest.mark.parametrize('name', GRAD_MESHES)
def test_vertex_normals_pass_gradcheck(name):
    v, f = GRAD_MESHES[name]()
    # The last vertex of these two is on a zero-area face only: its normal normalizes a vector that
    # is 0 up to rounding (torch.cross may fuse its products), so it jumps with any move (tested
    # finite above); the other vertices' normals are smooth.
    rows = slice(0, -1) if name in ('zero-area face', 'vertex with one neighbour') else slice(None)
    gradcheck(lambda x: losses.vertex_normals(x, f)[rows], v)


# ----------------------------------------------------------------------------
# Large steps


def test_the_large_steps_matrix_of_one_triangle_is_identity_plus_lambda_times_its_graph_laplacian():
    v = torch.rand(4, 3, dtype=F64)  # vertex 3 is isolated
    f = torch.tensor([[0, 1, 2]], dtype=torch.int32)
    L = torch.tensor([[2, -1, -1, 0], [-1, 2, -1, 0], [-1, -1, 2, 0], [0, 0, 0, 0]], dtype=F64)
    torch.testing.assert_close(losses.large_steps_matrix(v, f, lambda_=3.0), torch.eye(4, dtype=F64) + 3 * L)
    torch.testing.assert_close(losses.large_steps_matrix(v, f, alpha=0.25), 0.75 * torch.eye(4, dtype=F64) + 0.25 * L)
    # Edges shared by two faces and a face repeating an index count once / not at all.
    f2 = torch.tensor([[0, 1, 2], [2, 1, 3], [3, 3, 1]])
    M = losses.large_steps_matrix(v, f2, lambda_=1.0)
    torch.testing.assert_close(M.diagonal(), torch.tensor([3.0, 4.0, 4.0, 3.0], dtype=F64))
    assert M[1, 2] == -1 and M[0, 3] == 0 and torch.equal(M, M.T)


@pytest.mark.parametrize('dtype', [torch.float32, torch.float64])
def test_large_steps_round_trips_and_agrees_with_the_dense_functions(dtype):
    v, f = grid(6, bump=0.3)
    v = v.to(dtype)
    ls = losses.LargeSteps(v, f, lambda_=10.0)
    M = losses.large_steps_matrix(v, f, lambda_=10.0)
    u = ls.to_differential(v)
    assert u.dtype == dtype and ls.from_differential(u).dtype == dtype
    tol = dict(rtol=1e-5, atol=1e-5) if dtype == torch.float32 else dict(rtol=1e-12, atol=1e-12)
    torch.testing.assert_close(u, losses.to_differential(v, M), **tol)
    torch.testing.assert_close(ls.from_differential(u), v, **tol)
    torch.testing.assert_close(losses.from_differential(losses.to_differential(v, M), M), v, **tol)


def test_large_steps_gradients_solve_with_the_same_matrix():
    v, f = random_mesh(8)
    ls = losses.LargeSteps(v, f, lambda_=5.0)
    M = ls.matrix
    g = torch.rand(v.shape, dtype=F64)
    u = ls.to_differential(v).requires_grad_()
    (gu,) = torch.autograd.grad(ls.from_differential(u), u, g)
    torch.testing.assert_close(gu, torch.linalg.solve(M, g), rtol=1e-12, atol=1e-12)
    gradcheck(ls.from_differential, u)
    gradcheck(ls.to_differential, v)
    gradcheck(lambda x: losses.from_differential(x, M), u)
    gradcheck(lambda x: losses.to_differential(x, M), v)


def test_large_steps_on_hard_meshes_pass_gradcheck():
    for make in HARD_CASES.values():
        v, f = make()
        ls = losses.LargeSteps(v, f, alpha=0.9)
        gradcheck(ls.from_differential, ls.to_differential(v))


def test_large_steps_smooths_the_step_a_gradient_takes():
    # A gradient at one vertex moves x = M^-1 u along its neighbourhood, not one vertex alone.
    v, f = grid(6)
    ls = losses.LargeSteps(v, f, lambda_=20.0)
    u = ls.to_differential(v).requires_grad_()
    x = ls.from_differential(u)
    (g,) = torch.autograd.grad(x[24, 2], u)
    step = ls.from_differential(u.detach() - g) - v
    moved = (step[:, 2].abs() > 1e-3 * step[:, 2].abs().max()).sum()
    assert moved > 10


# ----------------------------------------------------------------------------
# dtypes, determinism, errors


@pytest.mark.parametrize('fn', ['edge', 'uniform', 'cot', 'cotcurv', 'normal', 'normals'])
def test_float32_gives_float32_results_close_to_float64(fn):
    call = {'edge': lambda v, f: losses.mesh_edge_loss(v, f, 0.2),
            'uniform': lambda v, f: losses.mesh_laplacian_smoothing(v, f, 'uniform'),
            'cot': lambda v, f: losses.mesh_laplacian_smoothing(v, f, 'cot'),
            'cotcurv': lambda v, f: losses.mesh_laplacian_smoothing(v, f, 'cotcurv'),
            'normal': losses.mesh_normal_consistency, 'normals': losses.vertex_normals}[fn]
    v, f = random_mesh(9)
    v32 = v.float().requires_grad_()
    out32 = call(v32, f.int())
    assert out32.dtype == torch.float32
    torch.testing.assert_close(out32.double(), call(v, f), rtol=1e-5, atol=1e-6)
    (g,) = torch.autograd.grad(out32.sum(), v32)
    assert g.dtype == torch.float32 and torch.isfinite(g).all()


def everything(v, f):
    v = v.detach().clone().requires_grad_()
    outs = [losses.mesh_edge_loss(v, f, 0.01), losses.mesh_normal_consistency(v, f), losses.vertex_normals(v, f)]
    outs += [losses.mesh_laplacian_smoothing(v, f, m, d) for m in ('uniform', 'cot', 'cotcurv') for d in (False, True)]
    total = sum(o.sum() for o in outs)
    return outs + list(torch.autograd.grad(total, v))


@pytest.mark.parametrize('dtype', [torch.float32, torch.float64])
def test_losses_and_gradients_are_bit_identical_on_1_and_4_threads(dtype):
    v, f = grid(60, bump=0.3, jitter=0.004, seed=3)  # 3721 vertices, 7200 faces
    v = v.to(dtype)
    saved = torch.get_num_threads()
    try:
        runs = []
        for threads in (1, 4, 1):
            torch.set_num_threads(threads)
            runs.append(everything(v, f))
    finally:
        torch.set_num_threads(saved)
    for run in runs[1:]:
        for a, b in zip(runs[0], run):
            assert torch.equal(a, b)


ALL_MESH_FUNCTIONS = {
    'mesh_edge_loss': losses.mesh_edge_loss, 'mesh_laplacian_smoothing': losses.mesh_laplacian_smoothing,
    'mesh_normal_consistency': losses.mesh_normal_consistency, 'vertex_normals': losses.vertex_normals,
    'large_steps_matrix': lambda v, f: losses.large_steps_matrix(v, f, lambda_=1.0),
    'LargeSteps': lambda v, f: losses.LargeSteps(v, f, lambda_=1.0)}


@pytest.mark.parametrize('name', ALL_MESH_FUNCTIONS)
def test_bad_meshes_are_refused_with_errors_naming_the_function_and_argument(name):
    fn = ALL_MESH_FUNCTIONS[name]
    v, f = tetrahedron()
    with pytest.raises(ValueError, match=rf"{name}: 'verts' must have shape \[V, 3\], got \[4, 2\]"):
        fn(v[:, :2], f)
    with pytest.raises(TypeError, match=rf"{name}: 'verts' must be float32 or float64, got torch.int64"):
        fn(v.long(), f)
    with pytest.raises(TypeError, match=rf"{name}: 'faces' must have an integer dtype"):
        fn(v, f.double())
    with pytest.raises(ValueError, match=rf"{name}: 'faces' must have shape \[F, 3\], got \[4, 4\]"):
        fn(v, torch.cat([f, f[:, :1]], 1))
    with pytest.raises(IndexError, match=rf"{name}: 'faces' holds vertex index 4, outside \[0, 4\)"):
        fn(v, torch.tensor([[0, 1, 4]]))
    with pytest.raises(IndexError, match=rf"{name}: 'faces' holds vertex index -1"):
        fn(v, torch.tensor([[0, -1, 2]], dtype=torch.int32))
    with pytest.raises(TypeError, match=rf"{name}: 'verts' must be a torch.Tensor"):
        fn(v.tolist(), f)


def test_other_bad_arguments_are_refused():
    v, f = tetrahedron()
    with pytest.raises(ValueError, match="'method' must be 'uniform', 'cot' or 'cotcurv', got 'cotan'"):
        losses.mesh_laplacian_smoothing(v, f, 'cotan')
    with pytest.raises(ValueError, match="give 'lambda_' or 'alpha', not both"):
        losses.LargeSteps(v, f, lambda_=1.0, alpha=0.5)
    with pytest.raises(ValueError, match="'lambda_' must be a number >= 0"):
        losses.LargeSteps(v, f)
    with pytest.raises(ValueError, match=r"'alpha' must be in \[0, 1\)"):
        losses.large_steps_matrix(v, f, alpha=1.0)
    M = losses.large_steps_matrix(v, f, lambda_=1.0)
    with pytest.raises(TypeError, match="'u' and 'M' must both be float32 or both float64"):
        losses.from_differential(v.float(), M)
    with pytest.raises(ValueError, match=r"'verts' must have shape \[V, C\] with V = 4"):
        losses.to_differential(v[:3], M)
    with pytest.raises(ValueError, match="'M' is not symmetric positive definite"):
        losses.from_differential(v, -M)
    ls = losses.LargeSteps(v, f, lambda_=1.0)
    with pytest.raises(ValueError, match=r"LargeSteps.from_differential: 'u' must have shape \[V, C\] with V = 4"):
        ls.from_differential(v[:2])
