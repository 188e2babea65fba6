"""RasterizeVulkanContext keeps rasterize's G-buffers on the device: interpolate, antialias (visibility_antialias
too) and the rasterize backward read the device's copy (no upload of rast; in range mode interpolate and the
rasterize backward read each image's copy with its range's triangles, antialias with the whole list its topology
indexes, the copy's ids offset by the range's first row) while
rast, rast_db, pos and tri are the very tensors rasterize made or read, unwritten since, and upload them otherwise (a
tensor written in place or a copy, a G-buffer the pool let go), with the CPU context's values within 1e-6 and
gradients within 1e-5 either way, and the same bits uploaded or not (glctx.residency counts the uploads).
The pool grows to the largest minibatch unless `frames` fixes it. Textures (2D and cube maps) stay too: later calls
on the very tensor, unwritten since (torch's _version), read the device's copy; one written in place or another tensor
is uploaded, with the CPU context's results (glctx.texture_residency counts); so is one written where torch does not
count (through .data or a numpy view), which a fingerprint of the texels sees. Skipped where there is no Vulkan
device."""
import pytest
import torch

import gradraster.torch as dr
from gradraster import _core

from test_vulkan_context import (assert_grads_close, assert_values_close, grid_mesh, leaf, shared_vulkan_context,
                                 vulkan_context)

RESOLUTION = (32, 40)


def chain(glctx, pos, tri, attr, change=None, antialias=dr.antialias):
    """rasterize -> interpolate (diff_attrs) -> antialias (or visibility_antialias) -> backward; `change` alters an
    input of interpolate and antialias after rasterize (pos then takes no gradient). Returns the outputs and
    gradients."""
    p, a = (pos.clone() if change else leaf(pos)), leaf(attr)
    rast, db = dr.rasterize(glctx, p, tri, RESOLUTION)
    t, d, q = tri, db, p
    with torch.no_grad():
        if change == 'rast written':
            rast[..., :2] *= 0.75
        elif change == 'pos written':
            p[..., 0] += 0.01
        elif change == 'rast_db copied':
            d = db.clone()
        elif change == 'pos copied':
            q = p.clone()
        elif change == 'tri copied':
            t = tri.clone()
    out, da = dr.interpolate(a, rast, t, rast_db=d, diff_attrs='all')
    image = antialias(out, rast, q, t)
    (image.square().sum() + da.square().sum()).backward()
    grads = [a.grad] + ([] if change else [p.grad])
    return [rast, db, out, da, image], grads


def compare(gpu, cpu):
    (values_g, grads_g), (values_c, grads_c) = gpu, cpu
    assert torch.equal(values_g[0], values_c[0]) and torch.equal(values_g[1], values_c[1])  # rast, rast_db
    for name, g, c in zip(('out', 'out_da', 'antialiased'), values_g[2:], values_c[2:]):
        assert_values_close(g, c, name)
    for name, g, c in zip(('attr gradient', 'pos gradient'), grads_g, grads_c):
        assert_grads_close(g, c, name)


def scene(images):
    pos, tri = grid_mesh(20 + images, images=images)
    return pos, tri, torch.rand(pos.shape[1], 3, generator=torch.Generator().manual_seed(images))


def kept(tri, gbuffers, resident_calls, frames, calls_per_image=6):
    """ctx.residency when every call read a kept G-buffer and each frame ran antialias on tri and its adjoint:
    the edge topology (built once, _topologies.py) went up once per frame, 4 bytes per edge, and so did the
    triangle list (each frame keeps the last one it uploaded), 12 bytes per triangle; each antialias and
    interpolate adjoint read what its forward left on the device (no second pair pass or interpolation); every
    image's calls (rasterize, interpolate, antialias and their adjoints: six, five where pos needs no gradient)
    were submitted without waiting."""
    return {'gbuffers': gbuffers, 'resident_calls': resident_calls, 'uploads': 0, 'frames': frames,
            'topology_uploads': frames, 'topology_bytes': frames * 12 * tri.shape[0],
            'triangle_uploads': frames, 'triangle_bytes': frames * 12 * tri.shape[0], 'antialias_reused': gbuffers,
            'interpolate_reused': gbuffers, 'deferred_calls': calls_per_image * gbuffers}


def test_the_chain_reads_the_kept_gbuffers_with_no_upload_and_gives_the_cpu_contexts_values_and_gradients():
    pos, tri, attr = scene(2)
    ctx = vulkan_context()
    compare(chain(ctx, pos, tri, attr), chain(dr.RasterizeCpuContext(), pos, tri, attr))
    # Per image: interpolate, antialias and their adjoints, the rasterize adjoint.
    assert ctx.residency == kept(tri, gbuffers=2, resident_calls=2 * 5, frames=2)
    assert ctx.device_calls == 2 * 6


def test_visibility_antialias_reads_the_kept_gbuffers_with_no_upload_either():
    pos, tri, attr = scene(2)
    ctx = vulkan_context()
    compare(chain(ctx, pos, tri, attr, antialias=dr.visibility_antialias),
            chain(dr.RasterizeCpuContext(), pos, tri, attr, antialias=dr.visibility_antialias))
    assert ctx.residency == kept(tri, gbuffers=2, resident_calls=2 * 5, frames=2)
    assert ctx.device_calls == 2 * 6


# Per image, the calls that upload: interpolate's two when rast, rast_db or tri changed, antialias's two when rast,
# pos or tri did.
CHANGES = {'rast written': 4, 'pos written': 2, 'rast_db copied': 2, 'pos copied': 2, 'tri copied': 4}


@pytest.mark.parametrize('change', CHANGES)
def test_a_tensor_written_in_place_or_copied_after_rasterize_is_uploaded_with_the_same_results(change):
    pos, tri, attr = scene(2)
    ctx = vulkan_context()
    compare(chain(ctx, pos, tri, attr, change), chain(dr.RasterizeCpuContext(), pos, tri, attr, change))
    stats = ctx.residency
    assert stats['uploads'] == 2 * CHANGES[change]
    assert stats['resident_calls'] == 2 * (4 - CHANGES[change])
    assert ctx.device_calls == 2 * 5  # all on the device: rasterize, interpolate, antialias, their adjoints


def test_two_antialiases_on_one_rast_give_the_cpu_contexts_gradients_whichever_pairs_the_device_kept():
    # The second's pairs replace the first's on the device: its backward (run first) reads them, the first's
    # recomputes its own.
    pos, tri, attr = scene(2)
    results = []
    for glctx in (vulkan_context(), dr.RasterizeCpuContext()):
        p, a = leaf(pos), leaf(attr)
        rast, _ = dr.rasterize(glctx, p, tri, RESOLUTION)
        out, _ = dr.interpolate(a, rast, tri)
        first, second = dr.antialias(out, rast, p, tri), dr.antialias(out.square(), rast, p, tri)
        (first.sum() + (second * 2).sum()).backward()
        results.append(([first, second, p.grad, a.grad], glctx))
    (got, glctx), (want, _) = results
    for name, g, c in zip(('first', 'second'), got[:2], want[:2]):
        assert_values_close(g, c, name)
    for name, g, c in zip(('pos gradient', 'attr gradient'), got[2:], want[2:]):
        assert_grads_close(g, c, name)
    assert glctx.residency['antialias_reused'] == 2 and glctx.residency['uploads'] == 0  # the second's, per image


def test_the_pool_grows_to_the_largest_minibatch_so_none_is_uploaded():
    pos, tri, attr = scene(6)
    ctx = vulkan_context()
    compare(chain(ctx, pos, tri, attr), chain(dr.RasterizeCpuContext(), pos, tri, attr))
    assert ctx.residency == kept(tri, gbuffers=6, resident_calls=6 * 5, frames=6)


def test_a_minibatch_larger_than_a_fixed_pool_is_uploaded_with_the_same_results():
    pos, tri, attr = scene(5)
    resident = chain(vulkan_context(), pos, tri, attr)
    ctx = dr.RasterizeVulkanContext(frames=2)
    uploaded = chain(ctx, pos, tri, attr)
    compare(uploaded, chain(dr.RasterizeCpuContext(), pos, tri, attr))
    stats = ctx.residency
    assert stats['frames'] == 2 and stats['uploads'] > 0
    assert stats['uploads'] + stats['resident_calls'] == 5 * 5
    # The device's results are the same bits whether it read its copy or the uploaded tensors.
    for r, u in zip(resident[0] + resident[1], uploaded[0] + uploaded[1]):
        assert torch.equal(r, u)


def test_the_backward_reads_the_gbuffers_after_a_later_rasterize_while_the_pool_holds_them():
    pos, tri, attr = scene(2)
    ctx = vulkan_context()
    a = leaf(attr)
    images = []
    for k in range(2):  # two renders alive at once (4 frames): each backward reads its own
        p = pos * (1 + 0.1 * k)
        rast, db = dr.rasterize(ctx, p, tri, RESOLUTION)
        out, da = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs=[0])
        images.append(dr.antialias(out, rast, p, tri))
    sum(i.sum() for i in images).backward()
    assert ctx.residency == kept(tri, gbuffers=4, resident_calls=4 * 4, frames=4, calls_per_image=5)


def test_depth_peeled_layers_keep_their_gbuffers_on_the_device():
    pos, tri, attr = scene(2)
    ctx = vulkan_context()
    p, a = leaf(pos), leaf(attr)
    images = []
    with dr.DepthPeeler(ctx, p, tri, RESOLUTION) as peeler:
        for _ in range(2):
            rast, db = peeler.rasterize_next_layer()
            out, _ = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
            images.append(dr.antialias(out, rast, p, tri))
    sum(i.square().sum() for i in images).backward()
    assert ctx.residency == kept(tri, gbuffers=4, resident_calls=4 * 5, frames=4)


# ---------------------------------------------------------------------------- range mode
# Each image's copy was rasterized from its range's triangles only (its ids numbered from 1 in the range): interpolate
# and the rasterize adjoint read it with the range's triangles and the ids made local to it, as the C++ batches do;
# antialias reads it with the whole list (its edge topology indexes them all: a walk may leave the range, as on the
# CPU), the device adding the range's first row to the copy's ids.

RANGES = {  # tri has 144 triangles
    'first above 0': [[72, 72], [10, 100]],
    'an empty range': [[0, 144], [30, 0], [50, 60]],
    'overlapping ranges': [[0, 90], [40, 104], [40, 104]],
}


def range_chain(glctx, flat, tri, attr, ranges, write_rast=False):
    """Range mode rasterize -> interpolate (diff_attrs) -> backward, to pos through rast and rast_db unless
    `write_rast` (rast written in place after rasterize: pos then takes no gradient). Returns the outputs and
    gradients."""
    p, a = (flat.clone() if write_rast else leaf(flat)), leaf(attr)
    rast, db = dr.rasterize(glctx, p, tri, RESOLUTION, ranges=torch.tensor(ranges, dtype=torch.int32))
    if write_rast:
        with torch.no_grad():
            rast.add_(0)  # the same values, a new version: the kept copies no longer count
    out, da = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
    (out.square().sum() + da.square().sum()).backward()
    return [rast, db, out, da], [a.grad] + ([] if write_rast else [p.grad])


def compare_range_runs(gpu, cpu):
    (values_g, grads_g), (values_c, grads_c) = gpu, cpu
    assert torch.equal(values_g[0], values_c[0]) and torch.equal(values_g[1], values_c[1])  # rast, rast_db
    for name, g, c in zip(('out', 'out_da'), values_g[2:], values_c[2:]):
        assert_values_close(g, c, name)
    for name, g, c in zip(('attr gradient', 'pos gradient'), grads_g, grads_c):
        assert_grads_close(g, c, name)


def assert_same_bits(a, b):
    for x, y in zip(a[0] + a[1], b[0] + b[1]):
        assert torch.equal(x, y)


@pytest.mark.parametrize('ranges', RANGES)
def test_range_mode_interpolate_and_the_backward_read_the_kept_copies_with_no_gbuffer_upload(ranges):
    pos, tri, attr = scene(1)
    ranges = RANGES[ranges]
    images = len(ranges)
    ctx = vulkan_context()
    resident = range_chain(ctx, pos[0], tri, attr, ranges)
    compare_range_runs(resident, range_chain(dr.RasterizeCpuContext(), pos[0], tri, attr, ranges))
    stats = ctx.residency
    # Per image: interpolate and its adjoint, the rasterize adjoint; each frame drew its range's triangles.
    assert stats['gbuffers'] == images and stats['uploads'] == 0
    assert stats['resident_calls'] == 3 * images
    assert stats['triangle_uploads'] == images
    assert stats['triangle_bytes'] == 12 * sum(count for _, count in ranges)
    assert ctx.device_calls == 4 * images
    # The device's results are the same bits whether it read its copies or uploaded the tensors (a pool of one
    # frame keeps only the last image's copy).
    small = dr.RasterizeVulkanContext(frames=1)
    assert_same_bits(range_chain(small, pos[0], tri, attr, ranges), resident)
    assert small.residency['uploads'] == 3 * (images - 1)


@pytest.mark.parametrize('ranges', RANGES)
def test_range_mode_rast_written_in_place_is_uploaded_with_the_same_bits(ranges):
    pos, tri, attr = scene(1)
    ranges = RANGES[ranges]
    images = len(ranges)
    ctx = vulkan_context()
    kept = range_chain(ctx, pos[0].clone(), tri, attr, ranges)  # pos takes no gradient here either
    before = ctx.residency
    written = range_chain(ctx, pos[0], tri, attr, ranges, write_rast=True)
    compare_range_runs(written, range_chain(dr.RasterizeCpuContext(), pos[0], tri, attr, ranges, write_rast=True))
    stats = ctx.residency
    assert before['uploads'] == 0 and before['resident_calls'] == 3 * images
    assert stats['uploads'] == 2 * images  # interpolate and its adjoint
    assert stats['resident_calls'] == before['resident_calls']
    assert torch.equal(written[0][2], kept[0][2]) and torch.equal(written[0][3], kept[0][3])  # out, out_da
    assert torch.equal(written[1][0], kept[1][0])  # the attr gradient


def test_range_mode_depth_peeled_layers_keep_their_gbuffers_on_the_device():
    pos, tri, attr = scene(1)
    ranges = torch.tensor(RANGES['first above 0'], dtype=torch.int32)
    runs = []
    ctx = vulkan_context()
    for glctx in (ctx, dr.RasterizeCpuContext()):
        p, a = leaf(pos[0]), leaf(attr)
        values = []
        with dr.DepthPeeler(glctx, p, tri, RESOLUTION, ranges=ranges) as peeler:
            for _ in range(2):
                rast, db = peeler.rasterize_next_layer()
                out, da = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
                values += [rast, db, out, da]
        sum(v.square().sum() for v in values[2::4] + values[3::4]).backward()
        runs.append((values, [a.grad, p.grad]))
    for layer in range(2):
        compare_range_runs((runs[0][0][4 * layer:4 * layer + 4], runs[0][1] if layer else []),
                           (runs[1][0][4 * layer:4 * layer + 4], runs[1][1] if layer else []))
    # 2 images x 2 layers, each read by interpolate, its adjoint and the rasterize adjoint.
    assert ctx.residency['uploads'] == 0 and ctx.residency['resident_calls'] == 4 * 3


@pytest.mark.parametrize('antialias', [dr.antialias, dr.visibility_antialias])
@pytest.mark.parametrize('ranges', [[[0, 144]] * 2, [[0, 40], [30, 42]], [[72, 72], [10, 100], [30, 0]],
                                    [[40, 104], [40, 104], [0, 90]]])
def test_antialias_reads_a_range_copy_with_no_upload_and_gives_the_cpu_contexts_values_and_gradients(ranges,
                                                                                                   antialias):
    pos, tri, attr = scene(1)
    assert tri.shape[0] == 144
    flat = pos[0]
    images = len(ranges)
    ranges = torch.tensor(ranges, dtype=torch.int32)
    runs = []
    ctx = vulkan_context()
    for glctx in (ctx, dr.RasterizeCpuContext()):
        p, a = leaf(flat), leaf(attr)
        rast, db = dr.rasterize(glctx, p, tri, RESOLUTION, ranges=ranges)
        out, da = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
        image = antialias(out, rast, p, tri)
        (image.square().sum() + da.square().sum()).backward()
        runs.append(([rast, db, out, da, image], [a.grad, p.grad]))
    compare(*runs)
    # Per image: interpolate and its adjoint, antialias and its adjoint, the rasterize adjoint, all on the copy.
    stats = ctx.residency
    assert stats['uploads'] == 0 and stats['resident_calls'] == 5 * images
    assert ctx.device_calls == 6 * images  # and the rasterize
    # The edge topology of the whole list goes up once per frame; so does the whole list where the frame's range
    # is not all of it, besides the range's own triangles.
    partial = sum(1 for first, count in ranges.tolist() if (first, count) != (0, 144))
    assert stats['topology_uploads'] == images
    assert stats['triangle_uploads'] == images + partial
    assert stats['triangle_bytes'] == 12 * (int(ranges[:, 1].sum()) + 144 * partial)
    # The same bits as the device gives uploading the G-buffers (a pool of one frame keeps only the last image's).
    small = dr.RasterizeVulkanContext(frames=1)
    p, a = leaf(flat), leaf(attr)
    rast, db = dr.rasterize(small, p, tri, RESOLUTION, ranges=ranges)
    out, da = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
    image = antialias(out, rast, p, tri)
    (image.square().sum() + da.square().sum()).backward()
    assert small.residency['uploads'] == 5 * (images - 1)
    for x, y in zip([image, a.grad, p.grad], [runs[0][0][4]] + runs[0][1]):
        assert torch.equal(x, y)


def test_repeated_renders_of_one_mesh_upload_its_edge_topology_and_triangles_once_per_frame():
    pos, tri, attr = scene(1)
    ctx = vulkan_context()
    cpu = dr.RasterizeCpuContext()
    for _ in range(4):  # an optimisation loop: antialias without topology_hash, forward and backward
        compare(chain(ctx, pos, tri, attr), chain(cpu, pos, tri, attr))
    stats = ctx.residency
    assert stats['uploads'] == 0
    assert stats['topology_uploads'] == stats['frames'] < 2 * 4  # not once per antialias call, forward or backward
    assert stats['topology_bytes'] == stats['frames'] * 12 * tri.shape[0]
    assert stats['triangle_uploads'] == stats['frames']  # not once per rasterize
    assert stats['triangle_bytes'] == stats['frames'] * 12 * tri.shape[0]


def test_a_written_tri_uploads_its_new_edge_topology_and_triangles():
    pos, tri, attr = scene(1)
    ctx = vulkan_context()
    chain(ctx, pos, tri, attr)
    before = ctx.residency
    with torch.no_grad():
        tri.data[:] = tri.flip(0).clone()  # the same triangles in another order: another adjacency
    compare(chain(ctx, pos, tri, attr), chain(dr.RasterizeCpuContext(), pos, tri, attr))
    assert ctx.residency['topology_uploads'] == before['topology_uploads'] + 1
    assert ctx.residency['triangle_uploads'] == before['triangle_uploads'] + 1


def test_frames_must_be_none_or_a_positive_integer():
    vulkan_context()
    with pytest.raises(ValueError, match="'frames' must be at least 1"):
        dr.RasterizeVulkanContext(frames=0)
    with pytest.raises(TypeError, match="'frames'"):
        dr.RasterizeVulkanContext(frames=2.0)



@pytest.mark.parametrize('written', ['rast', 'tri'])
def test_a_tensor_written_between_a_forward_and_its_backward_is_refused_so_the_backward_never_reads_a_stale_copy(
        written):
    pos, tri, attr = scene(1)
    tri = tri.clone()
    a = leaf(attr)
    rast, db = dr.rasterize(vulkan_context(), pos, tri, RESOLUTION)
    out, _ = dr.interpolate(a, rast, tri, rast_db=db, diff_attrs='all')
    with torch.no_grad():
        {'rast': rast, 'tri': tri}[written].add_(0)
    with pytest.raises(RuntimeError, match='modified by an inplace operation'):
        out.sum().backward()


# ---------------------------------------------------------------------------- textures across calls
# A RasterizeVulkanContext keeps the handles of the textures its texture calls kept on the device
# (_resident.KeptTextures): later calls on the very tensor, unwritten since, read the device's copy.

TEXTURE_KINDS = {  # filter, boundary, mip
    '2D bilinear': ('linear', 'wrap', None),
    '2D trilinear': ('linear-mipmap-linear', 'wrap', None),
    '2D prebuilt mip': ('linear-mipmap-linear', 'clamp', 'prebuilt'),
    '2D user mip': ('linear-mipmap-linear', 'wrap', 'user'),
    'cube bilinear': ('linear', 'cube', None),
    'cube trilinear': ('linear-mipmap-linear', 'cube', None),
}


def texture_of(kind, seed=0):
    """A leaf texture for `kind` (and its user mip levels, for 'user')."""
    g = torch.Generator().manual_seed(seed)
    _, boundary, mip = TEXTURE_KINDS[kind]
    shape = (1, 6, 16, 16, 3) if boundary == 'cube' else (1, 16, 24, 3)
    levels = [leaf(torch.rand(1, 8, 12, 3, generator=g)), leaf(torch.rand(1, 4, 6, 3, generator=g))]
    return leaf(torch.rand(*shape, generator=g)), levels if mip == 'user' else None


def view(glctx, kind, tex, levels=None, seed=0, mip=None):
    """One view (seeded) of `tex` through rasterize and interpolate: its samples and the gradients of tex (and the
    user levels); tex.grad is reset first."""
    filter_mode, boundary, mip_kind = TEXTURE_KINDS[kind]
    pos, tri = grid_mesh(30 + seed)
    attr = torch.rand(pos.shape[1], 3 if boundary == 'cube' else 2, generator=torch.Generator().manual_seed(seed))
    if boundary == 'cube':
        attr = attr * 2 - 1
    rast, db = dr.rasterize(glctx, pos, tri, RESOLUTION)
    uv, uv_da = dr.interpolate(attr, rast, tri, rast_db=db, diff_attrs='all')
    tex.grad = None
    kw = {}
    if mip_kind == 'user':
        kw['mip'] = levels
    elif mip_kind == 'prebuilt':
        kw['mip'] = mip
    out = dr.texture(tex, uv, uv_da, filter_mode=filter_mode, boundary_mode=boundary, **kw)
    (out * torch.linspace(-1, 1, out.numel()).reshape(out.shape)).sum().backward()
    return out.detach(), tex.grad.clone()


def texture_delta(glctx, before):
    after = glctx.texture_residency
    return after['uploads'] - before['uploads'], after['resident_calls'] - before['resident_calls']


def cpu_view(kind, tex, levels, seed, prebuilt):
    t = leaf(tex.detach())
    mip = dr.texture_construct_mip(t) if prebuilt is not None else None
    return view(dr.RasterizeCpuContext(), kind, t, levels, seed, mip)


@pytest.mark.parametrize('kind', TEXTURE_KINDS)
def test_two_calls_on_the_same_texture_upload_it_once_with_the_cpu_contexts_results(kind):
    glctx = shared_vulkan_context()
    tex, levels = texture_of(kind)
    mip = dr.texture_construct_mip(tex) if TEXTURE_KINDS[kind][2] == 'prebuilt' else None
    before = glctx.texture_residency
    got = [view(glctx, kind, tex, levels, seed, mip) for seed in range(2)]
    # 2 calls, forward and backward each: the first forward uploads, the other 3 read its copy.
    assert texture_delta(glctx, before) == (1, 3)
    # Level 0 and the levels given (the user's or prebuilt); the device builds the others from level 0.
    given = sum(m.numel() for m in levels) if levels else mip.pyramid.numel() if mip is not None else 0
    assert glctx.texture_residency['upload_bytes'] - before['upload_bytes'] == (tex.numel() + given) * 4
    assert glctx.texture_residency['textures'] >= 1
    for seed, (out, g) in enumerate(got):
        out_c, g_c = cpu_view(kind, tex, levels, seed, mip)
        assert_values_close(out, out_c, 'samples')
        assert_grads_close(g, g_c, 'tex gradient')
        # The same bits as a call that uploads (another tensor with these values).
        copy = leaf(tex.detach())
        copy_mip = dr.texture_construct_mip(copy) if mip is not None else None
        out_u, g_u = view(glctx, kind, copy, levels, seed, copy_mip)
        assert torch.equal(out, out_u) and torch.equal(g, g_u)


@pytest.mark.parametrize('write', ['in place', 'optimizer step'])
@pytest.mark.parametrize('kind', ['2D trilinear', 'cube trilinear'])
def test_a_texture_written_in_place_between_calls_is_uploaded_again_with_the_cpu_contexts_results(kind, write):
    glctx = shared_vulkan_context()
    tex, levels = texture_of(kind, seed=1)
    optimizer = torch.optim.SGD([tex], lr=0.5)
    before = glctx.texture_residency
    first, _ = view(glctx, kind, tex, levels)
    if write == 'in place':
        with torch.no_grad():
            tex.mul_(0.5)
    else:
        optimizer.step()
    out, g = view(glctx, kind, tex, levels)
    assert texture_delta(glctx, before) == (2, 2)
    assert not torch.equal(out, first)
    out_c, g_c = cpu_view(kind, tex, levels, 0, None)
    assert_values_close(out, out_c, 'samples')
    assert_grads_close(g, g_c, 'tex gradient')


def write_unseen_by_torch(t, write):
    """Writes t's values in a way torch's version counter does not count (t._version stays)."""
    version = t._version
    if write == '.data.mul_':
        t.data.mul_(0.5)
    elif write == '.data -=':
        t.data -= 0.1
    elif write == '.data.clamp_':
        t.data.clamp_(0.25, 0.75)
    else:  # a numpy view of the same memory
        t.detach().numpy()[..., 0] *= -1
    assert t._version == version


@pytest.mark.parametrize('write', ['.data.mul_', '.data -=', '.data.clamp_', 'numpy view'])
@pytest.mark.parametrize('kind', ['2D trilinear', 'cube trilinear', '2D prebuilt mip', '2D user mip'])
def test_a_texture_written_through_data_or_numpy_between_calls_is_uploaded_again_with_the_cpu_contexts_results(
        kind, write):
    glctx = shared_vulkan_context()
    tex, levels = texture_of(kind, seed=6)
    mip = dr.texture_construct_mip(tex) if kind == '2D prebuilt mip' else None
    before = glctx.texture_residency
    first, _ = view(glctx, kind, tex, levels, mip=mip)
    # The texels the device kept: tex, the prebuilt stack, a user level.
    written = mip.pyramid if mip is not None else levels[0] if levels else tex
    write_unseen_by_torch(written, write)
    out, g = view(glctx, kind, tex, levels, mip=mip)
    assert texture_delta(glctx, before) == (2, 2)  # each forward uploads, its backward reads its copy
    assert not torch.equal(out, first)
    out_c, g_c = view(dr.RasterizeCpuContext(), kind, leaf(tex.detach()), levels, mip=mip)
    assert_values_close(out, out_c, 'samples')
    assert_grads_close(g, g_c, 'tex gradient')


def test_an_unchanged_texture_is_uploaded_once_over_many_calls_however_often_its_data_is_read():
    glctx = shared_vulkan_context()
    tex, _ = texture_of('2D trilinear', seed=7)
    before = glctx.texture_residency
    outs = []
    for seed in range(4):
        outs.append(view(glctx, '2D trilinear', tex, seed=seed % 2)[0])
        assert torch.isfinite(tex.data.sum()) and tex.detach().numpy().max() <= 1  # reads, no write
    assert texture_delta(glctx, before) == (1, 7)
    assert glctx.texture_residency['upload_bytes'] - before['upload_bytes'] == tex.numel() * 4
    assert torch.equal(outs[0], outs[2]) and torch.equal(outs[1], outs[3])


def test_the_fingerprint_is_the_same_for_any_thread_count_and_changes_with_any_one_bit():
    from gradraster.torch.ops import _fingerprint
    g = torch.Generator().manual_seed(8)
    # Sizes around the 8-byte words, the 4 lanes and the 64 KiB chunks; float32, float64 and int32.
    tensors = [torch.rand(n, generator=g) for n in (0, 1, 2, 7, 9, 16385, 3 * 65536 // 4 + 3)]
    tensors += [torch.rand(1, 96, 80, 3, generator=g, dtype=torch.float64),
                torch.randint(-9, 9, (5, 7, 3), generator=g, dtype=torch.int32)]
    threads = torch.get_num_threads()
    try:
        for t in tensors:
            prints = {_core.fingerprint(t, n) for n in (1, 2, 3, 8)}
            for n in (1, 2):
                torch.set_num_threads(n)
                prints.add(_fingerprint(t))
            assert len(prints) == 1, list(t.shape)
    finally:
        torch.set_num_threads(threads)
    big = tensors[-3]
    base = _core.fingerprint(big, 2)
    assert base != _core.fingerprint(torch.zeros(0), 2)
    seen = {base}
    raw = big.view(torch.int32)
    for index in (0, 1, 4096, 16384, 16385, raw.numel() - 1):  # each 32-bit element's low and high bits
        for bit in (0, 31):
            changed = raw.clone()
            changed[index] ^= 1 << bit if bit < 31 else -2 ** 31
            seen.add(_core.fingerprint(changed, 2))
    assert len(seen) == 1 + 6 * 2
    # Same bytes, another length: the length counts.
    assert _core.fingerprint(torch.zeros(4), 1) != _core.fingerprint(torch.zeros(3), 1)
    with pytest.raises(ValueError, match="contiguous"):
        _core.fingerprint(torch.rand(4, 6).t(), 1)


def test_a_different_tensor_with_the_same_values_is_uploaded_and_gives_the_same_bits():
    glctx = shared_vulkan_context()
    tex, _ = texture_of('2D trilinear', seed=2)
    twin = leaf(tex.detach())
    before = glctx.texture_residency
    got = view(glctx, '2D trilinear', tex)
    twin_got = view(glctx, '2D trilinear', twin)
    assert texture_delta(glctx, before) == (2, 2)
    assert torch.equal(got[0], twin_got[0]) and torch.equal(got[1], twin_got[1])
    # A user mip level that is another tensor: the texels differ, so does the key.
    tex, levels = texture_of('2D user mip', seed=3)
    view(glctx, '2D user mip', tex, levels)
    before = glctx.texture_residency
    other = [leaf(levels[0].detach() * 0.5), levels[1]]
    out, _ = view(glctx, '2D user mip', tex, other)
    assert texture_delta(glctx, before) == (1, 1)
    out_c, _ = cpu_view('2D user mip', tex, other, 0, None)
    assert_values_close(out, out_c, 'samples')


def test_a_context_keeps_at_most_its_textures_least_recently_used_forgotten_first():
    glctx = dr.RasterizeVulkanContext(textures=1)
    a, _ = texture_of('2D bilinear', seed=4)
    b, _ = texture_of('2D bilinear', seed=5)
    before = glctx.texture_residency
    for tex in (a, b, a):  # b's handle pushes a's out: each call uploads
        view(glctx, '2D bilinear', tex)
    assert texture_delta(glctx, before) == (3, 3)
    assert glctx.texture_residency['textures'] == 1
    none_kept = dr.RasterizeVulkanContext(textures=0)
    before = none_kept.texture_residency
    for _ in range(2):  # the forward's copy still serves its backward
        view(none_kept, '2D bilinear', a)
    assert texture_delta(none_kept, before) == (2, 2)
    assert none_kept.texture_residency['textures'] == 0


def test_textures_must_be_a_non_negative_integer():
    with pytest.raises(ValueError, match="'textures' must be >= 0"):
        dr.RasterizeVulkanContext(textures=-1)
    with pytest.raises(TypeError, match="'textures'"):
        dr.RasterizeVulkanContext(textures=1.5)


def test_lookups_without_a_pyramid_are_refused_where_no_device_builds_the_levels():
    mode = _core.TextureMode()
    mode.levels, mode.filter, mode.device_levels = 3, 2, True
    tex, uv = torch.rand(1, 8, 8, 3), torch.rand(1, 4, 4, 2)
    da = torch.full((1, 4, 4, 2), 0.1)
    out = torch.empty(1, 4, 4, 3)
    with pytest.raises(ValueError, match="pyramid"):  # the CPU kernels
        _core.texture_forward(None, mode, tex, uv, da, da, None, None, out, None, 1)
    with pytest.raises(ValueError, match="pyramid"):  # a pyramid given as well
        _core.texture_forward(None, mode, tex, uv, da, da, None, torch.rand(1, 20, 3), out, None, 1)


def inference_render(glctx, pos, tri, attr, tex):
    """rasterize -> interpolate -> texture -> antialias under torch.inference_mode(), twice, tex written in place
    (which torch counts nowhere for inference tensors) between the two: the images."""
    images = []
    with torch.inference_mode():
        pos, tri, attr, tex = pos.clone(), tri.clone(), attr.clone(), tex.clone()
        for _ in range(2):
            rast, db = dr.rasterize(glctx, pos, tri, RESOLUTION)
            uv, uv_da = dr.interpolate(attr, rast, tri, rast_db=db, diff_attrs='all')
            images.append(dr.antialias(dr.texture(tex, uv, uv_da), rast, pos, tri))
            tex.mul_(0.5)
    return images


def test_inference_mode_tensors_run_on_the_device_with_the_cpu_contexts_results_and_no_stale_texture():
    pos, tri, _ = scene(2)
    attr = torch.rand(pos.shape[1], 2, generator=torch.Generator().manual_seed(3))
    tex = torch.rand(1, 16, 24, 3, generator=torch.Generator().manual_seed(4))
    glctx = vulkan_context()
    got = inference_render(glctx, pos, tri, attr, tex)
    want = inference_render(dr.RasterizeCpuContext(), pos, tri, attr, tex)
    assert glctx.device_calls == 2 * 2 * 4  # two renders of two images: rasterize, interpolate, texture, antialias
    for k, (g, c) in enumerate(zip(got, want)):
        assert_values_close(g, c, f'render {k}')
    # One upload per call (both images read the one texture): the written texture went up again.
    assert glctx.texture_residency['uploads'] == 2
    # interpolate and antialias read the kept G-buffers, matched by the inference tensors' fingerprints.
    assert glctx.residency['uploads'] == 0 and glctx.residency['resident_calls'] == 2 * 2 * 2


@pytest.mark.parametrize('write', ['rast', 'pos', 'tri'])
def test_an_inference_tensor_written_after_rasterize_is_uploaded_with_the_cpu_contexts_results(write):
    # Torch counts no write to an inference tensor: the fingerprint taken when rasterize kept the G-buffer sees it.
    pos, tri, attr = scene(1)
    results = []
    for glctx in (vulkan_context(), dr.RasterizeCpuContext()):
        with torch.inference_mode():
            p, t = pos.clone(), tri.clone()
            rast, _ = dr.rasterize(glctx, p, t, RESOLUTION)
            if write == 'rast':
                rast[..., :2] *= 0.75
            elif write == 'pos':
                p[..., 0] += 0.01
            else:
                t[:] = t.flip(1)  # the same triangles, wound the other way
            out, _ = dr.interpolate(attr, rast, t)
            results.append((dr.antialias(out, rast, p, t), glctx))
    (got, glctx), (want, _) = results
    assert_values_close(got, want, f'{write} written')
    # interpolate reads rast and tri (uploaded once rast or tri changed), antialias rast, pos and tri.
    uploads = {'rast': 2, 'pos': 1, 'tri': 2}[write]
    assert glctx.residency['uploads'] == uploads and glctx.residency['resident_calls'] == 2 - uploads


def test_an_interpolate_backward_given_another_calls_forward_state_is_refused_naming_it():
    pos, tri, attr = scene(2)
    glctx = vulkan_context()
    rast, _ = dr.rasterize(glctx, pos, tri, RESOLUTION)
    out = torch.empty(2, *RESOLUTION, 3)
    left = _core.interpolate_forward(glctx.cpp_wrapper, attr, rast, tri, None, [], out, None, 1)
    assert left is not None  # the device kept the attributes of both images
    one = rast[:1].contiguous()
    with pytest.raises(ValueError, match="'forward' is of a call with 2 images; these inputs have 1"):
        _core.interpolate_backward(glctx.cpp_wrapper, attr, one, tri, None, [], torch.ones(1, *RESOLUTION, 3), None,
                                   torch.zeros_like(attr), None, None, 1, None, left)
    # A CPU call keeps nothing.
    assert _core.interpolate_forward(None, attr, rast, tri, None, [], out, None, 1) is None
