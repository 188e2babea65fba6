"""texture: nvdiffrast's texel convention, filters and boundary modes, mip stacks, and gradients."""
import pytest
import torch
from torch.autograd import gradcheck

import gradraster.torch as dr


def texel_index_texture(h, w):
    """Texel (row j, column i) holds 10 j + i."""
    j, i = torch.meshgrid(torch.arange(h, dtype=torch.float64), torch.arange(w, dtype=torch.float64), indexing='ij')
    return (10 * j + i)[None, :, :, None]


def test_texel_centres_are_at_half_integers_with_row_zero_at_v_zero():
    tex = texel_index_texture(4, 8)
    # Texel (column 3, row 1) is centred at ((3 + 0.5) / 8, (1 + 0.5) / 4).
    uv = torch.tensor([[[[3.5 / 8, 1.5 / 4], [0.01, 0.01], [0.99, 0.99]]]], dtype=torch.float64)
    for mode in ('nearest', 'linear'):
        out = dr.texture(tex, uv, filter_mode=mode, boundary_mode='clamp')
        assert out[0, 0, 0, 0].item() == pytest.approx(13.0, abs=1e-12)
    near = dr.texture(tex, uv, filter_mode='nearest')
    assert near[0, 0, 1, 0].item() == 0.0 and near[0, 0, 2, 0].item() == 37.0


def test_linear_filtering_blends_the_four_nearest_texels_and_wrap_clamp_zero_differ_at_the_border():
    tex = texel_index_texture(4, 8)
    uv = torch.tensor([[[[4.0 / 8, 2.0 / 4], [0.0, 0.0]]]], dtype=torch.float64)  # a texel corner; the origin
    wrap = dr.texture(tex, uv, boundary_mode='wrap')
    clamp = dr.texture(tex, uv, boundary_mode='clamp')
    zero = dr.texture(tex, uv, boundary_mode='zero')
    assert wrap[0, 0, 0, 0].item() == pytest.approx((13 + 14 + 23 + 24) / 4)
    assert wrap[0, 0, 1, 0].item() == pytest.approx((0 + 7 + 30 + 37) / 4)   # wraps to the far sides
    assert clamp[0, 0, 1, 0].item() == pytest.approx(0.0)
    assert zero[0, 0, 1, 0].item() == pytest.approx(0.0 / 4)                  # three taps outside read 0


def test_the_level_of_detail_is_the_major_axis_of_the_footprint_as_in_nvdiffrast():
    tex = torch.rand(1, 16, 16, 3, dtype=torch.float64)
    uv = torch.rand(1, 2, 2, 2, dtype=torch.float64)
    # du/dX = du/dY = 2 texels: the ellipse's major axis is sqrt(8) texels, level 1.5
    # (OpenGL's isotropic rule would say 1); a bias of 1.5 alone selects the same level.
    sheared = torch.zeros(1, 2, 2, 4, dtype=torch.float64)
    sheared[..., 0] = sheared[..., 1] = 2 / 16
    bias = torch.full((1, 2, 2), 1.5, dtype=torch.float64)
    assert torch.allclose(dr.texture(tex, uv, sheared), dr.texture(tex, uv, mip_level_bias=bias), atol=1e-14)


def test_linear_mipmap_nearest_reads_level_floor_lod_only():
    tex = torch.rand(1, 16, 16, 3, dtype=torch.float64)
    uv = torch.rand(1, 2, 2, 2, dtype=torch.float64)
    level1 = tex.reshape(1, 8, 2, 8, 2, 3).mean((2, 4))  # the box-filtered level 1
    for lod in (1.0, 1.4, 1.9):
        bias = torch.full((1, 2, 2), lod, dtype=torch.float64)
        out = dr.texture(tex, uv, mip_level_bias=bias, filter_mode='linear-mipmap-nearest')
        assert torch.allclose(out, dr.texture(level1, uv, filter_mode='linear'), atol=1e-14)


def test_mipmapped_lookups_pick_the_level_from_uv_da_and_the_bias():
    tex = torch.rand(1, 16, 16, 3, dtype=torch.float64)
    uv = torch.rand(1, 4, 4, 2, dtype=torch.float64)
    one_texel = torch.zeros(1, 4, 4, 4, dtype=torch.float64)
    one_texel[..., 0] = 1 / 16                  # du/dX = one texel: level 0
    base = dr.texture(tex, uv, filter_mode='linear')
    assert torch.allclose(dr.texture(tex, uv, uv_da=one_texel), base, atol=1e-14)
    # A footprint of 4 texels is level 2; a bias of 2 alone is level 2 too.
    four = one_texel * 4
    bias = torch.full((1, 4, 4), 2.0, dtype=torch.float64)
    assert torch.allclose(dr.texture(tex, uv, uv_da=four), dr.texture(tex, uv, mip_level_bias=bias), atol=1e-14)
    assert torch.allclose(dr.texture(tex, uv, uv_da=one_texel, mip_level_bias=bias),
                          dr.texture(tex, uv, uv_da=four), atol=1e-14)
    # max_mip_level = 0 is plain linear filtering.
    assert torch.equal(dr.texture(tex, uv, uv_da=four, max_mip_level=0), base)


def test_a_prebuilt_mip_stack_gives_the_same_lookups_and_gradients():
    tex = torch.rand(2, 16, 8, 3, dtype=torch.float64, requires_grad=True)
    uv = torch.rand(2, 4, 4, 2, dtype=torch.float64)
    uv_da = torch.rand(2, 4, 4, 4, dtype=torch.float64) * 0.3
    mip = dr.texture_construct_mip(tex)
    a = dr.texture(tex, uv, uv_da, mip=mip)
    b = dr.texture(tex, uv, uv_da)
    assert torch.equal(a, b)
    ga, = torch.autograd.grad(a.sum(), tex)
    gb, = torch.autograd.grad(b.sum(), tex)
    assert torch.equal(ga, gb)


@pytest.mark.parametrize('boundary', ['wrap', 'clamp', 'zero'])
@pytest.mark.parametrize('filter_mode', ['linear', 'linear-mipmap-nearest', 'linear-mipmap-linear'])
def test_gradients_to_texels_uv_uv_da_and_bias_match_finite_differences(boundary, filter_mode):
    g = torch.Generator().manual_seed(3)
    tex = torch.rand(2, 8, 16, 2, generator=g, dtype=torch.float64, requires_grad=True)
    uv = (torch.rand(2, 3, 3, 2, generator=g, dtype=torch.float64) * 1.4 - 0.2).requires_grad_(True)
    # Footprints of 1.3..3.5 texels: LODs inside levels 0..2, away from integers.
    uv_da = (torch.rand(2, 3, 3, 4, generator=g, dtype=torch.float64) * 0.1 + 0.12).requires_grad_(True)
    bias = (torch.rand(2, 3, 3, generator=g, dtype=torch.float64) * 0.3).requires_grad_(True)
    if filter_mode != 'linear-mipmap-linear':  # no gradient to uv_da and bias: gradcheck checks they are 0
        f = lambda t, u, d, b: dr.texture(t, u, d, b, filter_mode=filter_mode, boundary_mode=boundary)
        assert gradcheck(f, (tex, uv, uv_da, bias), eps=1e-7, atol=1e-7)
    else:
        f = lambda t, u, d, b: dr.texture(t, u, d, b, boundary_mode=boundary)
        assert gradcheck(f, (tex, uv, uv_da, bias), eps=1e-7, atol=1e-7)


def test_a_user_mip_stack_gets_its_own_gradients_and_none_flows_to_the_base():
    g = torch.Generator().manual_seed(4)
    tex = torch.rand(1, 8, 8, 2, generator=g, dtype=torch.float64, requires_grad=True)
    mip = [torch.rand(1, 4, 4, 2, generator=g, dtype=torch.float64, requires_grad=True),
           torch.rand(1, 2, 2, 2, generator=g, dtype=torch.float64, requires_grad=True)]
    uv = torch.rand(1, 3, 3, 2, generator=g, dtype=torch.float64)
    uv_da = torch.rand(1, 3, 3, 4, generator=g, dtype=torch.float64) * 0.2 + 0.15
    assert gradcheck(lambda t, m1, m2: dr.texture(t, uv, uv_da, mip=[m1, m2]), (tex, *mip), eps=1e-7, atol=1e-7)


def test_a_custom_mip_list_for_a_cube_map_raises_not_implemented():
    tex = torch.rand(1, 6, 8, 8, 3)
    with pytest.raises(NotImplementedError, match='cube'):
        dr.texture(tex, torch.rand(1, 2, 2, 3), uv_da=torch.rand(1, 2, 2, 6), boundary_mode='cube',
                   mip=[torch.rand(1, 6, 4, 4, 3)])


def test_cube_map_directions_select_the_gl_faces_in_order():
    # Faces +X, -X, +Y, -Y, +Z, -Z hold 0..5; the axis directions hit their centres.
    faces = torch.arange(6, dtype=torch.float64).reshape(1, 6, 1, 1, 1).expand(1, 6, 4, 4, 1).contiguous()
    dirs = torch.tensor([[[[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]]],
                        dtype=torch.float64)
    for mode in ('nearest', 'linear'):
        out = dr.texture(faces, dirs * 3.0, boundary_mode='cube', filter_mode=mode)  # need not be normalised
        assert out.flatten().tolist() == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]


def cube_directions(generator, n, near_edges):
    d = torch.randn(1, n, n, 3, generator=generator, dtype=torch.float64)
    if near_edges:  # two components of equal size (an edge) or three (a corner), nudged off the tie
        d = d.sign() * torch.tensor([1.0, 0.97, 0.3], dtype=torch.float64)
        d[0, 0, 0] = torch.tensor([1.0, 0.99, -0.98], dtype=torch.float64)
    return d.requires_grad_(True)


@pytest.mark.parametrize('near_edges', [False, True])
@pytest.mark.parametrize('filter_mode', ['linear', 'linear-mipmap-linear'])
def test_cube_map_gradients_to_faces_directions_uv_da_and_bias_match_finite_differences(filter_mode, near_edges):
    g = torch.Generator().manual_seed(6)
    tex = torch.rand(1, 6, 8, 8, 2, generator=g, dtype=torch.float64, requires_grad=True)
    d = cube_directions(g, 3, near_edges)
    if filter_mode == 'linear':
        assert gradcheck(lambda t, u: dr.texture(t, u, boundary_mode='cube'), (tex, d), eps=1e-7, atol=1e-7)
        return
    da = (torch.randn(1, 3, 3, 6, generator=g, dtype=torch.float64) * 0.3).requires_grad_(True)
    bias = (torch.rand(1, 3, 3, generator=g, dtype=torch.float64) * 0.3).requires_grad_(True)
    assert gradcheck(lambda t, u, a, b: dr.texture(t, u, a, b, boundary_mode='cube'), (tex, d, da, bias),
                     eps=1e-7, atol=1e-6)


def test_a_prebuilt_cube_mip_stack_gives_the_same_lookups():
    g = torch.Generator().manual_seed(7)
    tex = torch.rand(2, 6, 8, 8, 3, generator=g, dtype=torch.float64)
    d = torch.randn(2, 4, 4, 3, generator=g, dtype=torch.float64)
    da = torch.randn(2, 4, 4, 6, generator=g, dtype=torch.float64) * 0.3
    mip = dr.texture_construct_mip(tex, cube_mode=True)
    assert torch.equal(dr.texture(tex, d, da, mip=mip, boundary_mode='cube'),
                       dr.texture(tex, d, da, boundary_mode='cube'))
    with pytest.raises(ValueError, match='cube_mode'):
        dr.texture(tex[:, 0].contiguous(), d[..., :2].contiguous(), da[..., :4].contiguous(), mip=mip)


def test_bad_texture_arguments_are_named():
    tex = torch.rand(1, 8, 8, 3)
    uv = torch.rand(1, 2, 2, 2)
    with pytest.raises(ValueError, match="'filter_mode' must be one of"):
        dr.texture(tex, uv, filter_mode='cubic')
    with pytest.raises(ValueError, match="'boundary_mode' must be one of"):
        dr.texture(tex, uv, boundary_mode='mirror')
    with pytest.raises(ValueError, match="6 square faces"):
        dr.texture(torch.rand(1, 6, 8, 4, 3), torch.rand(1, 2, 2, 3), boundary_mode='cube')
    with pytest.raises(ValueError, match="is a cube map: set boundary_mode='cube'"):
        dr.texture(torch.rand(1, 6, 8, 8, 3), uv)
    with pytest.raises(ValueError, match=r"'uv' must have shape \[minibatch_size, height, width, 3\] \(directions\)"):
        dr.texture(torch.rand(1, 6, 8, 8, 3), uv, boundary_mode='cube')
    with pytest.raises(ValueError, match="needs 'uv_da' or 'mip_level_bias'"):
        dr.texture(tex, uv, filter_mode='linear-mipmap-linear')
    with pytest.raises(ValueError, match=r"'uv_da' must have shape \[1, 2, 2, 4\]"):
        dr.texture(tex, uv, uv_da=torch.rand(1, 2, 2, 2))
    with pytest.raises(ValueError, match=r"'mip\[0\]' must have shape \[1, 4, 4, 3\]"):
        dr.texture(tex, uv, uv_da=torch.rand(1, 2, 2, 4), mip=[torch.rand(1, 4, 3, 3)])
    with pytest.raises(ValueError, match="'tex' has minibatch size 2 but 'uv' has 1"):
        dr.texture(torch.rand(2, 8, 8, 3), uv)
    with pytest.raises(TypeError, match="'uv' has dtype torch.float64 but 'tex' has torch.float32"):
        dr.texture(tex, uv.double())
    bad = uv.clone()
    bad[0, 1, 1, 0] = float('nan')
    with pytest.raises(ValueError, match='NaN'):
        dr.texture(tex, bad)


@pytest.mark.parametrize('built, used', [(torch.float32, torch.float64), (torch.float64, torch.float32)])
@pytest.mark.parametrize('cube', [False, True])
def test_a_mip_stack_built_in_another_dtype_is_refused_naming_mip(built, used, cube):
    shape = (1, 6, 16, 16, 3) if cube else (1, 16, 16, 3)
    tex = torch.rand(shape, dtype=used)
    uv = torch.rand(1, 4, 4, 3 if cube else 2, dtype=used)
    uv_da = torch.rand(1, 4, 4, 6 if cube else 4, dtype=used) * 0.3
    mip = dr.texture_construct_mip(tex.to(built), cube_mode=cube)
    with pytest.raises(TypeError, match=f"'mip' was built from a {built} texture but 'tex' is {used}"):
        dr.texture(tex, uv, uv_da, mip=mip, boundary_mode='cube' if cube else 'wrap')


def test_a_mip_stack_of_the_wrong_device_or_level_shapes_is_refused_naming_mip():
    tex = torch.rand(2, 16, 8, 3, dtype=torch.float64)
    uv = torch.rand(2, 4, 4, 2, dtype=torch.float64)
    uv_da = torch.rand(2, 4, 4, 4, dtype=torch.float64) * 0.3
    mip = dr.texture_construct_mip(tex)
    mip.pyramid = mip.pyramid.to('meta')
    with pytest.raises(ValueError, match="'mip' is on meta but 'tex' is on cpu"):
        dr.texture(tex, uv, uv_da, mip=mip)
    mip = dr.texture_construct_mip(tex)
    mip.pyramid = mip.pyramid[:, :-1]  # one texel short
    with pytest.raises(ValueError, match="'mip' holds a stack of shape"):
        dr.texture(tex, uv, uv_da, mip=mip)
    mip = dr.texture_construct_mip(tex)
    mip.sizes = mip.sizes[:1] + [(9, 4)] + mip.sizes[2:]
    with pytest.raises(ValueError, match="'mip' levels .* are not the mip chain of a 16 x 8 texture"):
        dr.texture(tex, uv, uv_da, mip=mip)


def test_a_huge_max_mip_level_means_the_whole_chain_not_a_type_error():
    tex = torch.rand(1, 16, 8, 3, dtype=torch.float64)
    uv = torch.rand(1, 4, 4, 2, dtype=torch.float64)
    uv_da = torch.rand(1, 4, 4, 4, dtype=torch.float64) * 2
    whole = dr.texture(tex, uv, uv_da)
    for level in (2 ** 40, 2 ** 31, 10 ** 100):
        assert torch.equal(dr.texture(tex, uv, uv_da, max_mip_level=level), whole)
        mip = dr.texture_construct_mip(tex, max_mip_level=level)
        assert torch.equal(dr.texture(tex, uv, uv_da, mip=mip), whole)
    for bad in (-1, 2.5, True, '3'):
        with pytest.raises(ValueError, match="'max_mip_level' must be None or an integer >= 0"):
            dr.texture(tex, uv, uv_da, max_mip_level=bad)



@pytest.mark.parametrize('filter_mode', ['linear-mipmap-linear', 'linear-mipmap-nearest'])
@pytest.mark.parametrize('cube', [False, True])
def test_a_mip_stack_built_with_max_mip_level_0_gives_the_lookups_and_gradients_of_level_0(cube, filter_mode):
    # nvdiffrast's texture_construct_mip(tex, max_mip_level=0): level 0 only, as texture(max_mip_level=0).
    g = torch.Generator().manual_seed(8)
    tex = torch.rand((1, 6, 8, 8, 3) if cube else (1, 8, 16, 3), generator=g, dtype=torch.float64, requires_grad=True)
    uv = torch.rand(2, 4, 4, 3 if cube else 2, generator=g, dtype=torch.float64) * 2 - 0.5
    uv_da = torch.rand(2, 4, 4, 6 if cube else 4, generator=g, dtype=torch.float64) * 0.5
    boundary = 'cube' if cube else 'wrap'
    mip = dr.texture_construct_mip(tex, max_mip_level=0, cube_mode=cube)
    assert mip.sizes == [tuple(tex.shape[-3:-1])]
    got = dr.texture(tex, uv, uv_da, mip=mip, filter_mode=filter_mode, boundary_mode=boundary)
    want = dr.texture(tex, uv, uv_da, filter_mode=filter_mode, boundary_mode=boundary, max_mip_level=0)
    assert torch.equal(got, want)
    w = torch.rand(want.shape, generator=g, dtype=torch.float64)
    assert torch.equal(torch.autograd.grad(got, tex, w)[0], torch.autograd.grad(want, tex, w)[0])



def test_the_mip_stack_of_a_1x1_texture_is_level_0_alone():
    tex = torch.rand(1, 1, 1, 3, dtype=torch.float64)
    uv, uv_da = torch.rand(1, 2, 2, 2, dtype=torch.float64), torch.rand(1, 2, 2, 4, dtype=torch.float64)
    mip = dr.texture_construct_mip(tex)
    assert mip.sizes == [(1, 1)]
    assert torch.equal(dr.texture(tex, uv, uv_da, mip=mip), dr.texture(tex, uv, uv_da))

@pytest.mark.parametrize('filter_mode', ['linear-mipmap-linear', 'linear-mipmap-nearest'])
@pytest.mark.parametrize('empty', ['no rows', 'no columns'])
def test_a_mipmapped_lookup_of_an_empty_image_gives_an_empty_result_and_zero_gradients(filter_mode, empty):
    tex = torch.rand(1, 8, 8, 3, dtype=torch.float64, requires_grad=True)
    size = (0, 3) if empty == 'no rows' else (3, 0)
    uv = torch.rand(2, *size, 2, dtype=torch.float64, requires_grad=True)
    uv_da = torch.rand(2, *size, 4, dtype=torch.float64, requires_grad=True)
    bias = torch.rand(2, *size, dtype=torch.float64, requires_grad=True)
    out = dr.texture(tex, uv, uv_da, bias, filter_mode=filter_mode)
    assert out.shape == (2, *size, 3)
    grads = torch.autograd.grad(out.sum(), (tex, uv, uv_da, bias), allow_unused=True)
    assert torch.equal(grads[0], torch.zeros_like(tex))
    assert all(g is None or g.shape == t.shape for g, t in zip(grads[1:], (uv, uv_da, bias)))
