"""Bad input: a clear Python exception naming the argument, never a crash or a silent copy."""
import pytest
import torch

import gradraster.torch as dr
from conftest import two_triangles


@pytest.fixture
def scene(glctx):
    pos, tri = two_triangles()
    rast, db = dr.rasterize(glctx, pos, tri, (8, 8))
    return pos, tri, rast, db


def test_a_tensor_on_another_device_is_refused_naming_it(glctx, scene):
    pos, tri, rast, _ = scene
    with pytest.raises(ValueError, match="'pos' is on meta"):
        dr.rasterize(glctx, pos.to('meta'), tri, (8, 8))
    with pytest.raises(ValueError, match="'attr' is on meta"):
        dr.interpolate(torch.zeros(4, 2, device='meta', dtype=torch.float64), rast, tri)


def test_non_contiguous_tensors_are_refused_not_copied(glctx, scene):
    pos, tri, rast, _ = scene
    with pytest.raises(ValueError, match="'pos' is not contiguous"):
        dr.rasterize(glctx, pos.transpose(1, 2).contiguous().transpose(1, 2), tri, (8, 8))
    color = torch.zeros(1, 8, 8, 6, dtype=torch.float64)[..., ::2]
    with pytest.raises(ValueError, match="'color' is not contiguous"):
        dr.antialias(color, rast, pos, tri)


def test_wrong_dtypes_are_type_errors_naming_the_argument(glctx, scene):
    pos, tri, rast, _ = scene
    with pytest.raises(TypeError, match="'tri' must have dtype torch.int32"):
        dr.rasterize(glctx, pos, tri.long(), (8, 8))
    with pytest.raises(TypeError, match="'pos' must have dtype"):
        dr.rasterize(glctx, pos.half(), tri, (8, 8))
    with pytest.raises(TypeError, match="'attr' has dtype torch.float32 but 'rast' has torch.float64"):
        dr.interpolate(torch.zeros(4, 2), rast, tri)
    with pytest.raises(TypeError, match="'glctx' must be a RasterizeCpuContext"):
        dr.rasterize(object(), pos, tri, (8, 8))


def test_wrong_shapes_are_value_errors_naming_the_argument(glctx, scene):
    pos, tri, rast, db = scene
    with pytest.raises(ValueError, match=r"'pos' must have shape \[..., num_vertices, 4\]"):
        dr.rasterize(glctx, pos[..., :3].contiguous(), tri, (8, 8))
    with pytest.raises(ValueError, match=r"'tri' must have shape \[num_triangles, 3\]"):
        dr.rasterize(glctx, pos, tri[:, :2].contiguous(), (8, 8))
    with pytest.raises(ValueError, match="range mode - 'pos' is \\[num_vertices, 4\\], so 'ranges'"):
        dr.rasterize(glctx, pos[0], tri, (8, 8))
    with pytest.raises(ValueError, match="'resolution' height = 0"):
        dr.rasterize(glctx, pos, tri, (0, 8))
    with pytest.raises(ValueError, match="'resolution' width = 16385 is outside 1..16384"):
        dr.rasterize(glctx, pos, tri, (8, 16385))
    with pytest.raises(TypeError, match="'resolution' height must be an integer"):
        dr.rasterize(glctx, pos, tri, (8.0, 8))
    with pytest.raises(ValueError, match="'attr' has minibatch size 2 but 'rast' has 1"):
        dr.interpolate(torch.zeros(2, 4, 3, dtype=torch.float64), rast, tri)
    with pytest.raises(ValueError, match="'rast_db' must have rast's shape"):
        dr.interpolate(pos[0], rast, tri, db[:, :4].contiguous(), diff_attrs='all')
    with pytest.raises(ValueError, match="'diff_attrs' needs 'rast_db'"):
        dr.interpolate(pos[0], rast, tri, diff_attrs=[0])
    with pytest.raises(ValueError, match="'diff_attrs' index 4 is outside 0..3"):
        dr.interpolate(pos[0], rast, tri, db, diff_attrs=[4])
    with pytest.raises(ValueError, match="'color' .* and 'rast' .* differ"):
        dr.antialias(torch.zeros(1, 8, 7, 3, dtype=torch.float64), rast, pos, tri)


def test_out_of_range_indices_ids_and_ranges_are_index_errors(glctx, scene):
    pos, tri, rast, _ = scene
    bad = tri.clone()
    bad[1, 2] = 4
    with pytest.raises(IndexError, match='rasterize'):
        dr.rasterize(glctx, pos, bad, (8, 8))
    bad[1, 2] = -1
    with pytest.raises(IndexError, match='rasterize'):
        dr.rasterize(glctx, pos, bad, (8, 8))
    with pytest.raises(IndexError, match=r"ranges\[1\] = \(1, 5\) is outside the 2 triangles"):
        dr.rasterize(glctx, pos[0], tri, (8, 8), ranges=torch.tensor([[0, 1], [1, 5]], dtype=torch.int32))
    forged = rast.clone()
    forged[0, 3, 3, 3] = 7.0
    with pytest.raises(IndexError, match=r"rast\[..., 3\] \(triangle id \+ 1\) at pixel 27 is 7"):
        dr.interpolate(pos[0], forged, tri)
    forged[0, 3, 3, 3] = 0.5
    with pytest.raises(IndexError, match='not an integer'):
        dr.antialias(torch.zeros(1, 8, 8, 1, dtype=torch.float64), forged, pos, tri)


def test_nan_or_inf_positions_are_value_errors_naming_the_element(glctx, scene):
    pos, tri, _, _ = scene
    bad = pos.clone()
    bad[0, 2, 1] = float('nan')
    with pytest.raises(ValueError, match=r"pos\[9\] is NaN or Inf"):
        dr.rasterize(glctx, bad, tri, (8, 8))
    bad[0, 2, 1] = float('inf')
    with pytest.raises(ValueError, match=r"pos\[9\] is NaN or Inf"):
        dr.antialias(torch.zeros(1, 8, 8, 1, dtype=torch.float64), scene[2], bad, tri)


def test_a_topology_hash_for_other_triangles_and_a_bad_boost_are_refused(glctx, scene):
    pos, tri, rast, _ = scene
    color = torch.zeros(1, 8, 8, 1, dtype=torch.float64)
    with pytest.raises(ValueError, match="'topology_hash' was built for 1 triangles but 'tri' has 2"):
        dr.antialias(color, rast, pos, tri, topology_hash=dr.antialias_construct_topology_hash(tri[:1].contiguous()))
    with pytest.raises(ValueError, match="'pos_gradient_boost' must be a finite number"):
        dr.antialias(color, rast, pos, tri, pos_gradient_boost=float('nan'))


def test_write_png_refuses_bad_images_and_unwritable_paths_without_leaving_a_file(tmp_path):
    import gradraster
    with pytest.raises(ValueError, match="'image' must be"):
        gradraster.write_png(tmp_path / 'a.png', torch.zeros(4, 4, 5))
    with pytest.raises(OSError):
        gradraster.write_png(tmp_path / 'missing' / 'a.png', torch.zeros(4, 4, 3))
    assert list(tmp_path.iterdir()) == []
    gradraster.write_png(tmp_path / 'b.png', torch.rand(4, 4))
    assert (tmp_path / 'b.png').read_bytes()[:4] == b'\x89PNG'


def test_arguments_that_are_not_tensors_are_type_errors_naming_them(glctx, scene):
    pos, tri, rast, _ = scene
    with pytest.raises(TypeError, match="'color' must be a torch.Tensor, got list"):
        dr.antialias([[0.0]], rast, pos, tri)
    with pytest.raises(TypeError, match="'pos' must be a torch.Tensor, got ndarray"):
        dr.rasterize(glctx, pos.numpy(), tri, (8, 8))
    with pytest.raises(TypeError, match="'tex' must be a torch.Tensor"):
        dr.texture(None, torch.zeros(1, 2, 2, 2))


def test_a_resolution_of_integer_tensors_is_taken_as_nvdiffrast_takes_it(glctx, scene):
    pos, tri, rast, db = scene
    for resolution in (torch.tensor([8, 8]), (torch.tensor(8), 8), torch.tensor([8, 8], dtype=torch.int32)):
        got, got_db = dr.rasterize(glctx, pos, tri, resolution)
        assert torch.equal(got, rast) and torch.equal(got_db, db)
    with pytest.raises(TypeError, match="'resolution' height must be an integer, got tensor"):
        dr.rasterize(glctx, pos, tri, torch.tensor([8.0, 8.0]))
    with pytest.raises(TypeError, match="'resolution' width must be an integer"):
        dr.rasterize(glctx, pos, tri, (8, torch.tensor(True)))
    with pytest.raises(ValueError, match="'resolution' height = -8 is outside"):
        dr.rasterize(glctx, pos, tri, torch.tensor([-8, 8]))


def test_a_0_dim_tensor_is_taken_for_a_number_argument(glctx, scene):
    pos, tri, rast, _ = scene
    color = torch.rand(1, 8, 8, 2, dtype=torch.float64)
    boost = dr.antialias(color, rast, pos, tri, pos_gradient_boost=torch.tensor(2.0))
    assert torch.equal(boost, dr.antialias(color, rast, pos, tri, pos_gradient_boost=2.0))
    with pytest.raises(ValueError, match="'pos_gradient_boost' must be a finite number"):
        dr.antialias(color, rast, pos, tri, pos_gradient_boost=torch.tensor([2.0]))
    tex = torch.rand(1, 8, 8, 2, dtype=torch.float64)
    uv = torch.rand(1, 3, 3, 2, dtype=torch.float64)
    bias = torch.full((1, 3, 3), 2.0, dtype=torch.float64)
    assert torch.equal(dr.texture(tex, uv, mip_level_bias=bias, max_mip_level=torch.tensor(1)),
                       dr.texture(tex, uv, mip_level_bias=bias, max_mip_level=1))
    with pytest.raises(ValueError, match="'max_mip_level' must be None or an integer >= 0"):
        dr.texture(tex, uv, mip_level_bias=bias, max_mip_level=torch.tensor(1.0))


def test_arguments_of_the_wrong_kind_are_type_errors_naming_them_not_torch_or_python_internals(scene):
    pos, tri, rast, db = scene
    with pytest.raises(TypeError, match="'diff_attrs' must be 'all' or a list of attribute indices, got 1"):
        dr.interpolate(pos[0], rast, tri, db, diff_attrs=1)
    with pytest.raises(TypeError, match="'diff_attrs' must be 'all' or a list of attribute indices"):
        dr.interpolate(pos[0], rast, tri, db, diff_attrs=torch.tensor(1))
    tex, uv = torch.rand(1, 4, 4, 1, dtype=torch.float64), torch.rand(1, 2, 2, 2, dtype=torch.float64)
    with pytest.raises(ValueError, match="'filter_mode' must be one of"):
        dr.texture(tex, uv, filter_mode=['linear'])
    with pytest.raises(ValueError, match="'boundary_mode' must be one of"):
        dr.texture(tex, uv, boundary_mode={'wrap': 0})
