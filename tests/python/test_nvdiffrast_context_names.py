"""nvdiffrast's context names: programs that name RasterizeGLContext or RasterizeCudaContext (in type
annotations, isinstance checks or construction) run with only their import line changed."""
import pathlib

import pytest
import torch

import gradraster.torch as dr

PROGRAM = pathlib.Path(__file__).with_name('nvdiffrast_shadow_map_program.py')


@pytest.mark.parametrize('kind', ['gl', 'cuda'])
def test_a_third_party_shadow_map_program_imports_and_runs_unchanged(kind):
    # The program's nvdiffrast version differs in its import line alone.
    lines = [line for line in PROGRAM.read_text().splitlines() if 'gradraster' in line]
    assert lines == ['import gradraster.torch as dr  # was: import nvdiffrast.torch as dr']
    import nvdiffrast_shadow_map_program as program
    image, grad = program.main(kind=kind, device='cpu')
    assert image.shape == (1, 64, 64, 3) and torch.isfinite(image).all() and torch.isfinite(grad).all()
    red = image[0, ..., 0]  # the grey floor is 0.8 lit and 0.24 in shadow
    assert (red > 0.7).sum() > 100 and ((red > 0.15) & (red < 0.3)).sum() > 10
    assert grad[4:].abs().sum() > 0  # moving the triangle moves its shadow
    same, _ = program.main(kind='cuda' if kind == 'gl' else 'gl', device='cpu')
    assert torch.equal(image, same)


@pytest.mark.parametrize('make', [lambda **kw: dr.RasterizeCudaContext(**kw),
                                  lambda **kw: dr.RasterizeGLContext(**kw)], ids=['cuda', 'gl'])
def test_constructing_either_name_gives_a_cpu_context_and_refuses_other_devices(make):
    for device in (None, 'cpu', torch.device('cpu')):
        ctx = make(device=device)
        assert isinstance(ctx, dr.RasterizeCpuContext) and ctx.device == torch.device('cpu')
    with pytest.raises(ValueError, match="'device' is cuda:0, but gradraster runs on the CPU"):
        make(device='cuda:0')
    with pytest.raises(ValueError, match="'device' must be None or a torch device"):
        make(device='gpu7')


def test_a_gl_context_without_output_db_gives_an_empty_rast_db_as_nvdiffrast():
    pos = torch.tensor([[[-0.8, -0.8, 0, 1], [0.8, -0.8, 0, 1], [0, 0.8, 0, 1]]])
    tri = torch.tensor([[0, 1, 2]], dtype=torch.int32)
    rast, db = dr.rasterize(dr.RasterizeGLContext(output_db=False), pos, tri, (8, 8))
    assert db.shape == (1, 8, 8, 0)
    assert torch.equal(rast, dr.rasterize(dr.RasterizeCudaContext(), pos, tri, (8, 8))[0])


def test_gl_context_modes_are_checked_and_manual_mode_takes_set_and_release_calls():
    manual = dr.RasterizeGLContext(mode='manual')
    manual.set_context()
    manual.release_context()
    with pytest.raises(RuntimeError, match="set_context\\(\\) is for mode='manual'"):
        dr.RasterizeGLContext().set_context()
    with pytest.raises(ValueError, match="'mode' must be 'automatic' or 'manual'"):
        dr.RasterizeGLContext(mode='auto')
    with pytest.raises(TypeError, match="'output_db' must be True or False"):
        dr.RasterizeGLContext(output_db=1)
