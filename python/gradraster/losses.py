"""Mesh losses and reparametrizations, as torch functions (docs/python.md, "Mesh losses").

Everything here is plain torch on tensors of any device: autograd gives the
gradients, and float32 and float64 both work (results have the dtype of
`verts`). A mesh is `verts` [V, 3] (float32 or float64) and `faces` [F, 3]
(any integer dtype, each index in [0, V)); faces may repeat a vertex index
(a degenerate face), and vertices used by no face are allowed.

- `mesh_edge_loss`, `mesh_laplacian_smoothing`, `mesh_normal_consistency`:
  the definitions of PyTorch3D's functions of the same names
  (`pytorch3d.loss`) for a batch holding this one mesh; each docstring says
  what is computed and where it differs.
- `vertex_normals`: area-weighted vertex normals.
- `LargeSteps`, `large_steps_matrix`, `to_differential`, `from_differential`:
  the reparametrization u = (I + lambda L) x of Nicolet et al. 2021, "Large
  Steps in Inverse Rendering of Geometry", with a dense Cholesky solve.

Determinism: the per-vertex sums use `Tensor.index_add` (and its backward,
`index_select`), and gathers use `index_select` (whose backward is
`index_add`). Torch's CPU `index_add` adds the source rows in the order of
the index, one after the other (each row added elementwise), so a sum never
depends on the thread count; tests/python/test_losses.py checks that losses
and gradients are bit-identical on 1 and 4 threads. The large-steps solve
calls LAPACK through torch (`torch.linalg.cholesky`, `torch.cholesky_solve`):
deterministic with a single-threaded BLAS (Debian's torch links the
reference BLAS/LAPACK); a threaded BLAS (OpenBLAS, MKL) may change the last
bits of the solve with its thread count.
"""
import torch

__all__ = ['mesh_edge_loss', 'mesh_laplacian_smoothing', 'mesh_normal_consistency', 'vertex_normals',
           'LargeSteps', 'large_steps_matrix', 'to_differential', 'from_differential']

_INTEGER_DTYPES = (torch.uint8, torch.int8, torch.int16, torch.int32, torch.int64)


# ----------------------------------------------------------------------------
# Input checks and mesh topology


def _check_verts(verts, fn, name='verts'):
    if not isinstance(verts, torch.Tensor):
        raise TypeError(f"{fn}: '{name}' must be a torch.Tensor, got {type(verts).__name__}")
    if verts.dtype not in (torch.float32, torch.float64):
        raise TypeError(f"{fn}: '{name}' must be float32 or float64, got {verts.dtype}")
    if verts.dim() != 2 or verts.shape[1] != 3:
        raise ValueError(f"{fn}: '{name}' must have shape [V, 3], got {list(verts.shape)}")


def _check_faces(faces, num_verts, device, fn, name='faces', verts_name='verts', rows='F'):
    """faces as int64 [F, 3] on `device`, after checking them (named `name`,
    shape written [rows, 3]; `verts_name` names the tensor they index)."""
    if not isinstance(faces, torch.Tensor):
        raise TypeError(f"{fn}: '{name}' must be a torch.Tensor, got {type(faces).__name__}")
    if faces.dtype not in _INTEGER_DTYPES:
        raise TypeError(f"{fn}: '{name}' must have an integer dtype (vertex indices), got {faces.dtype}")
    if faces.dim() != 2 or faces.shape[1] != 3:
        raise ValueError(f"{fn}: '{name}' must have shape [{rows}, 3], got {list(faces.shape)}")
    if faces.device != device:
        raise ValueError(f"{fn}: '{name}' is on {faces.device} but '{verts_name}' is on {device}")
    faces = faces.long()
    if faces.numel() > 0:
        lo, hi = int(faces.min()), int(faces.max())
        if lo < 0 or hi >= num_verts:
            bad = lo if lo < 0 else hi
            raise IndexError(f"{fn}: '{name}' holds vertex index {bad}, outside [0, {num_verts}) "
                             f"('{verts_name}' has {num_verts} rows)")
    return faces


def _check_mesh(verts, faces, fn):
    _check_verts(verts, fn)
    return _check_faces(faces, verts.shape[0], verts.device, fn)


def _gather(verts, index):
    """verts[index] for an int64 index of any shape, through index_select
    (whose backward is the in-order index_add)."""
    return verts.index_select(0, index.reshape(-1)).reshape(*index.shape, verts.shape[1])


def _row_sums(values, index, num_rows):
    """out[i] = sum of values[k] over k with index[k] == i, added in order of k."""
    return values.new_zeros((num_rows,) + tuple(values.shape[1:])).index_add(0, index, values)


def _edges(faces, num_verts):
    """The mesh's distinct undirected edges and each face side's edge.

    Side k of face f is the edge opposite corner k: (faces[f, k+1], faces[f, k+2]).
    Returns `edges` [E, 2] (int64, edges[e, 0] <= edges[e, 1], sorted by
    (edges[e, 0], edges[e, 1])) and `side_edge` [F, 3] (int64 into edges).
    A face repeating an index gives a side (i, i), kept as an edge, as
    PyTorch3D's Meshes.edges_packed keeps it."""
    a, b = faces[:, [1, 2, 0]], faces[:, [2, 0, 1]]
    lo, hi = torch.minimum(a, b), torch.maximum(a, b)
    keys, side_edge = torch.unique(lo * num_verts + hi, sorted=True, return_inverse=True)
    edges = torch.stack([torch.div(keys, num_verts, rounding_mode='floor'), keys % num_verts], dim=1)
    return edges, side_edge.reshape(faces.shape)


def _zero_loss(verts):
    """A zero scalar of verts' dtype connected to verts (gradient zero, even where verts has NaNs)."""
    return verts[:0].sum()


# ----------------------------------------------------------------------------
# Losses


def mesh_edge_loss(verts, faces, target_length=0.0):
    """Mean over the mesh's distinct edges (i, j) of (|v_i - v_j| - target_length)^2.

    Matches `pytorch3d.loss.mesh_edge_loss(meshes, target_length)` for a batch
    of this one mesh: edges are the distinct unordered vertex pairs of the
    face sides (an edge shared by several faces counts once), and the mean is
    over all of them. A mesh without faces gives 0 (as PyTorch3D, which returns
    a float32 [1] tensor there; this returns a 0-dim tensor of verts' dtype).
    At a zero-length edge the gradient of |v_i - v_j| is taken as 0 (torch's
    norm), which is also the symmetric difference quotient there."""
    faces = _check_mesh(verts, faces, 'mesh_edge_loss')
    if faces.shape[0] == 0:
        return _zero_loss(verts)
    edges, _ = _edges(faces, verts.shape[0])
    length = torch.linalg.vector_norm(_gather(verts, edges[:, 0]) - _gather(verts, edges[:, 1]), dim=1)
    return ((length - target_length) ** 2).mean()


def _cot_weights(verts, faces, eps=1e-12):
    """PyTorch3D's cot_laplacian, rewritten: for each face, the cotangent of
    the angle at each corner from the side lengths, cot = (b^2 + c^2 - a^2) /
    (4 area) with a the opposite side, and the area from Heron's formula with
    its square clamped below at eps (so area >= 1e-6 and degenerate faces get
    large finite weights). Returns cot [F, 3] and area [F]."""
    p0, p1, p2 = _gather(verts, faces[:, 0]), _gather(verts, faces[:, 1]), _gather(verts, faces[:, 2])
    a = torch.linalg.vector_norm(p1 - p2, dim=1)  # opposite corner 0
    b = torch.linalg.vector_norm(p0 - p2, dim=1)  # opposite corner 1
    c = torch.linalg.vector_norm(p0 - p1, dim=1)  # opposite corner 2
    s = 0.5 * (a + b + c)
    area = (s * (s - a) * (s - b) * (s - c)).clamp(min=eps).sqrt()
    a2, b2, c2 = a * a, b * b, c * c
    cot = torch.stack([b2 + c2 - a2, a2 + c2 - b2, a2 + b2 - c2], dim=1) / (4.0 * area[:, None])
    return cot, area


def _laplacian_smoothing(verts, faces, method, weight_verts):
    """mesh_laplacian_smoothing with the cotangent weights computed from
    `weight_verts` (verts.detach() for PyTorch3D's constant weights)."""
    V = verts.shape[0]
    if method == 'uniform':
        edges, _ = _edges(faces, V)
        src = torch.cat([edges[:, 0], edges[:, 1]])
        dst = torch.cat([edges[:, 1], edges[:, 0]])
        degree = _row_sums(verts.new_ones(src.shape[0]), src, V)
        inv_degree = torch.where(degree > 0, 1.0 / degree.clamp(min=1), degree)
        residual = _row_sums(_gather(verts, dst), src, V) * inv_degree[:, None] - verts
    else:
        cot, area = _cot_weights(weight_verts, faces)
        # W[i, j] = sum of cot of the angles opposite the edge (i, j): corner k
        # of a face adds its cotangent to W[i, j] and W[j, i] for its opposite side.
        i, j = faces[:, [1, 2, 0]].reshape(-1), faces[:, [2, 0, 1]].reshape(-1)
        src, dst, w = torch.cat([i, j]), torch.cat([j, i]), torch.cat([cot.reshape(-1), cot.reshape(-1)])
        weighted = _row_sums(w[:, None] * _gather(verts, dst), src, V)  # (W v)_i
        weight_sum = _row_sums(w, src, V)                                # sum_j W[i, j]
        if method == 'cot':
            # As PyTorch3D: rows whose weights sum to <= 0 are not normalized
            # (the raw sum multiplies; an isolated vertex gets residual -v_i).
            scale = torch.where(weight_sum > 0, 1.0 / torch.where(weight_sum > 0, weight_sum, 1.0), weight_sum)
            residual = weighted * scale[:, None] - verts
        else:
            vertex_area = _row_sums(area.repeat_interleave(3), faces.reshape(-1), V)
            inv_area = torch.where(vertex_area > 0, 1.0 / torch.where(vertex_area > 0, vertex_area, 1.0), vertex_area)
            residual = (weighted - weight_sum[:, None] * verts) * (0.25 * inv_area)[:, None]
    return torch.linalg.vector_norm(residual, dim=1).mean()


def mesh_laplacian_smoothing(verts, faces, method='uniform', differentiable_weights=False):
    """Mean over all V vertices of |r_i|, r_i a Laplacian of the positions at vertex i.

    Matches `pytorch3d.loss.mesh_laplacian_smoothing(meshes, method)` for a
    batch of this one mesh, value and gradient:

    - 'uniform': r_i = (1/deg_i) sum_{j in N(i)} v_j - v_i, N(i) the distinct
      edge neighbours of i (a face side (i, i) of a face repeating an index
      counts i twice, as PyTorch3D's Meshes.laplacian_packed does); an
      isolated vertex has r_i = -v_i.
    - 'cot': r_i = sum_j w_ij v_j / sum_j w_ij - v_i with w_ij = cot a_ij +
      cot b_ij, the cotangents of the angles opposite edge (i, j) in its faces
      (one term per face: a boundary edge has one, an edge of k faces k). As
      PyTorch3D, a row whose weights sum to <= 0 is multiplied by that sum
      instead of its inverse (so an isolated vertex has r_i = -v_i).
    - 'cotcurv': r_i = sum_j w_ij (v_j - v_i) / (4 A_i), A_i the summed area of
      the faces at i (0 for an isolated vertex: r_i = 0).

    Cotangents are cot = (b^2 + c^2 - a^2) / (4 area) per corner (a the
    opposite side, area by Heron's formula with area^2 clamped to >= 1e-12,
    so a zero-area face gives large finite weights), as PyTorch3D's
    cot_laplacian. The weights (w_ij, the normalization, 1/A_i) are constants
    for the gradient, as in PyTorch3D (computed under no_grad there);
    `differentiable_weights=True` differentiates through them too, giving the
    gradient of the value itself. A mesh without faces gives 0.

    Differences: none in the value beyond rounding (PyTorch3D builds its
    matrices in float32 whatever the input; here the input's dtype is kept).
    """
    fn = 'mesh_laplacian_smoothing'
    faces = _check_mesh(verts, faces, fn)
    if method not in ('uniform', 'cot', 'cotcurv'):
        raise ValueError(f"{fn}: 'method' must be 'uniform', 'cot' or 'cotcurv', got {method!r}")
    if faces.shape[0] == 0:
        return _zero_loss(verts)
    return _laplacian_smoothing(verts, faces, method, verts if differentiable_weights else verts.detach())


def _normal_consistency_pairs(side_edge, num_edges):
    """All unordered pairs (p, q), p < q, of face sides (indices into
    side_edge.reshape(-1)) on the same edge."""
    flat = side_edge.reshape(-1)
    order = torch.sort(flat, stable=True).indices  # sides grouped by edge
    count = torch.bincount(flat, minlength=num_edges)
    start = torch.cumsum(count, 0) - count
    firsts, seconds = [], []
    for c in torch.unique(count).tolist():
        if c < 2:
            continue
        group_start = start[count == c]  # [G]
        p, q = torch.triu_indices(c, c, offset=1, device=flat.device)
        firsts.append(order[(group_start[:, None] + p[None, :]).reshape(-1)])
        seconds.append(order[(group_start[:, None] + q[None, :]).reshape(-1)])
    if not firsts:
        empty = flat.new_zeros(0)
        return empty, empty
    return torch.cat(firsts), torch.cat(seconds)


def mesh_normal_consistency(verts, faces, eps=1e-8):
    """Mean over all pairs of faces sharing an edge of 1 - cos(n_0, n_1).

    Matches `pytorch3d.loss.mesh_normal_consistency(meshes)` for a batch of
    this one mesh. For an edge e = (v_a, v_b), a < b, and a face with third
    vertex w, n = (v_b - v_a) x (w - v_a); for two faces with third vertices
    w0, w1 on the same edge the term is 1 - cos(n(w0), -n(w1)): 0 when the two
    faces lie flat in one plane (w0 and w1 on opposite sides), 2 when folded
    onto each other. The face orientation (index order) does not matter.
    Every unordered pair of faces on an edge counts once, so an edge shared by
    k faces gives k (k - 1) / 2 terms (PyTorch3D's current C++ pair search;
    its older Python version counted some pairs twice when k >= 4), and the
    mean is over all such pairs of the mesh. A mesh with no edge shared by two
    faces gives 0. Faces repeating an index are treated as PyTorch3D does
    (n summed over the face's three vertices, n = e x (p0 + p1 + p2 - 3 v_a)).

    cos(x, y) = x.y / (max(|x|, eps) max(|y|, eps)), as current torch's
    cosine_similarity (eps = 1e-8) documents it; torch 1.13's clamps |x| |y|
    instead. The two differ only where a normal is nearly zero. A zero-area face
    has n = 0, so cos = 0 and its terms are 1; the loss is discontinuous there
    (the normal's direction is undefined) and its gradient, though finite, is
    of order 1/eps."""
    faces = _check_mesh(verts, faces, 'mesh_normal_consistency')
    if faces.shape[0] == 0:
        return _zero_loss(verts)
    edges, side_edge = _edges(faces, verts.shape[0])
    first, second = _normal_consistency_pairs(side_edge, edges.shape[0])
    if first.numel() == 0:
        return _zero_loss(verts)
    # One normal per face side: n = (v_b - v_a) x (p0 + p1 + p2 - 3 v_a).
    side_face = torch.arange(faces.shape[0], device=faces.device).repeat_interleave(3)
    side = side_edge.reshape(-1)
    corners = _gather(verts, faces)  # [F, 3, 3]
    corner_sum = corners.sum(dim=1).index_select(0, side_face)
    va, vb = _gather(verts, edges[side, 0]), _gather(verts, edges[side, 1])
    n = torch.cross(vb - va, corner_sum - 3.0 * va, dim=1)
    n0, n1 = n.index_select(0, first), -n.index_select(0, second)
    norm0 = torch.linalg.vector_norm(n0, dim=1).clamp(min=eps)
    norm1 = torch.linalg.vector_norm(n1, dim=1).clamp(min=eps)
    cos = (n0 * n1).sum(dim=1) / (norm0 * norm1)
    return (1.0 - cos).mean()


def vertex_normals(verts, faces, eps=1e-12):
    """Area-weighted unit vertex normals [V, 3].

    Each face's cross product (p1 - p0) x (p2 - p0) (length twice its area;
    pointing to the side from which p0, p1, p2 appear counter-clockwise, the
    right-hand rule) is added to its three corners, and each sum s_i is
    divided by max(|s_i|, eps). A vertex of no face, or whose faces' normals
    cancel, gets 0. Same as the C++ gr::vertex_normals (ops/mesh/vertex_normals.h)
    and PyTorch3D's Meshes.verts_normals_packed, except that PyTorch3D uses
    eps = 1e-6 (pass eps=1e-6 for its values on tiny meshes)."""
    faces = _check_mesh(verts, faces, 'vertex_normals')
    p0, p1, p2 = _gather(verts, faces[:, 0]), _gather(verts, faces[:, 1]), _gather(verts, faces[:, 2])
    face_normal = torch.cross(p1 - p0, p2 - p0, dim=1)
    summed = _row_sums(face_normal.repeat_interleave(3, dim=0), faces.reshape(-1), verts.shape[0])
    return summed / torch.linalg.vector_norm(summed, dim=1, keepdim=True).clamp(min=eps)


# ----------------------------------------------------------------------------
# Large steps (Nicolet et al. 2021)


def _check_large_steps_params(lambda_, alpha, fn):
    if alpha is None:
        if lambda_ is None or not lambda_ >= 0:
            raise ValueError(f"{fn}: 'lambda_' must be a number >= 0 (or give 'alpha' in [0, 1)), got {lambda_!r}")
        return 1.0, float(lambda_)
    if lambda_ is not None:
        raise ValueError(f"{fn}: give 'lambda_' or 'alpha', not both")
    if not 0 <= alpha < 1:
        raise ValueError(f"{fn}: 'alpha' must be in [0, 1), got {alpha!r}")
    return 1.0 - float(alpha), float(alpha)


def _uniform_graph_edges(faces, num_verts):
    """Distinct undirected edges (i, j), i < j, of the face sides (sides (i, i) dropped)."""
    edges, _ = _edges(faces, num_verts)
    return edges[edges[:, 0] != edges[:, 1]]


def large_steps_matrix(verts, faces, lambda_=None, alpha=None):
    """The dense [V, V] matrix M = I + lambda_ L (or (1 - alpha) I + alpha L),
    L = D - A the combinatorial (uniform, unnormalized) graph Laplacian of the
    mesh's edges: A[i, j] = 1 for each distinct edge, D the degrees. M is
    symmetric positive definite. dtype and device of `verts`; `verts` gives
    only the count V. Same matrix as the `largesteps` package's
    compute_matrix(verts, faces, lambda_, alpha) (cotan=False), dense."""
    fn = 'large_steps_matrix'
    faces = _check_mesh(verts, faces, fn)
    diag_weight, lap_weight = _check_large_steps_params(lambda_, alpha, fn)
    V = verts.shape[0]
    edges = _uniform_graph_edges(faces, V)
    M = torch.zeros(V, V, dtype=verts.dtype, device=verts.device)
    M[edges[:, 0], edges[:, 1]] = -lap_weight
    M[edges[:, 1], edges[:, 0]] = -lap_weight
    degree = torch.bincount(edges.reshape(-1), minlength=V).to(verts.dtype)
    M.diagonal().copy_(diag_weight + lap_weight * degree)
    return M


def _check_solve_operands(x, M, fn, name):
    if not isinstance(x, torch.Tensor) or not isinstance(M, torch.Tensor):
        raise TypeError(f"{fn}: '{name}' and 'M' must be torch.Tensors")
    if x.dtype not in (torch.float32, torch.float64) or M.dtype != x.dtype:
        raise TypeError(f"{fn}: '{name}' and 'M' must both be float32 or both float64, got {x.dtype} and {M.dtype}")
    if M.dim() != 2 or M.shape[0] != M.shape[1]:
        raise ValueError(f"{fn}: 'M' must be a square [V, V] matrix, got {list(M.shape)}")
    if x.dim() != 2 or x.shape[0] != M.shape[0]:
        raise ValueError(f"{fn}: '{name}' must have shape [V, C] with V = {M.shape[0]} (M's size), got {list(x.shape)}")


def to_differential(verts, M):
    """u = M @ verts: the differential coordinates [V, C] of positions `verts`
    for the dense matrix M of large_steps_matrix (as largesteps'
    to_differential). Gradients by autograd."""
    _check_solve_operands(verts, M, 'to_differential', 'verts')
    return M @ verts


def from_differential(u, M):
    """x = M^-1 u: positions [V, C] from differential coordinates `u` [V, C],
    M symmetric positive definite (large_steps_matrix's), by a dense Cholesky
    factorization of M on every call (use LargeSteps to factor once). The
    gradient, by autograd, solves with the same factor (M is symmetric);
    gradients also reach M if it requires them. Dense: O(V^2) memory and
    O(V^3) time, for meshes up to a few thousand vertices."""
    _check_solve_operands(u, M, 'from_differential', 'u')
    factor, info = torch.linalg.cholesky_ex(M)
    if int(info) != 0:
        raise ValueError("from_differential: 'M' is not symmetric positive definite "
                         f"(Cholesky failed at column {int(info)})")
    return torch.cholesky_solve(u, factor)


class LargeSteps:
    """The "large steps" reparametrization (Nicolet et al. 2021) of one mesh's
    vertex positions: optimize u = M x, M = I + lambda_ L (or (1 - alpha) I +
    alpha L; L = D - A, the uniform graph Laplacian, see large_steps_matrix),
    and get the positions back as x = M^-1 u.

        ls = LargeSteps(verts, faces, lambda_=20.0)
        u = ls.to_differential(verts).detach().requires_grad_()
        opt = torch.optim.Adam([u], lr=1e-2)   # the paper uses its AdamUniform
        ...  x = ls.from_differential(u); loss = render_loss(x); loss.backward(); opt.step()

    M is factored once, in float64, with a dense Cholesky
    (torch.linalg.cholesky): O(V^2) memory and O(V^3) time at construction,
    O(V^2) per solve, which suits meshes up to a few thousand vertices (no
    sparse path). from_differential solves in float64 and returns u's dtype;
    its gradient, by autograd through torch.cholesky_solve, solves with the
    same factor (M is symmetric). to_differential multiplies by M through the
    edge list (M x = diag_weight x + lap_weight (D x - A x), in-order sums),
    not a dense product."""

    def __init__(self, verts, faces, lambda_=None, alpha=None):
        fn = 'LargeSteps'
        faces = _check_mesh(verts, faces, fn)
        self.diag_weight, self.lap_weight = _check_large_steps_params(lambda_, alpha, fn)
        self.num_verts = verts.shape[0]
        self.edges = _uniform_graph_edges(faces, self.num_verts)
        self.degree = torch.bincount(self.edges.reshape(-1), minlength=self.num_verts)
        self.matrix = large_steps_matrix(verts.detach().to(torch.float64), faces, lambda_, alpha)
        factor, info = torch.linalg.cholesky_ex(self.matrix)
        if int(info) != 0:  # cannot happen for these matrices; kept as a guard
            raise ValueError(f"LargeSteps: the matrix is not positive definite (column {int(info)})")
        self.factor = factor

    def _check(self, x, name, fn):
        _check_verts_like(x, self.num_verts, name, f'LargeSteps.{fn}')

    def to_differential(self, x):
        """u = M x for positions x [V, C] (float32 or float64; u has x's dtype)."""
        self._check(x, 'x', 'to_differential')
        e0, e1 = self.edges[:, 0].to(x.device), self.edges[:, 1].to(x.device)
        src, dst = torch.cat([e0, e1]), torch.cat([e1, e0])
        neighbours = _row_sums(x.index_select(0, dst), src, self.num_verts)  # (A x)_i
        degree = self.degree.to(device=x.device, dtype=x.dtype)[:, None]
        return self.diag_weight * x + self.lap_weight * (degree * x - neighbours)

    def from_differential(self, u):
        """x = M^-1 u for u [V, C] (float32 or float64; x has u's dtype)."""
        self._check(u, 'u', 'from_differential')
        factor = self.factor.to(u.device)
        return torch.cholesky_solve(u.to(torch.float64), factor).to(u.dtype)


def _check_verts_like(x, num_verts, name, fn):
    if not isinstance(x, torch.Tensor):
        raise TypeError(f"{fn}: '{name}' must be a torch.Tensor, got {type(x).__name__}")
    if x.dtype not in (torch.float32, torch.float64):
        raise TypeError(f"{fn}: '{name}' must be float32 or float64, got {x.dtype}")
    if x.dim() != 2 or x.shape[0] != num_verts:
        raise ValueError(f"{fn}: '{name}' must have shape [V, C] with V = {num_verts}, got {list(x.shape)}")
