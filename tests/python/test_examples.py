"""The Python examples run end to end (a few small iterations) and write their PNGs."""
import os
import subprocess
import sys

import pytest

EXAMPLES = os.path.join(os.path.dirname(__file__), '..', '..', 'examples', 'python')


@pytest.mark.parametrize('name, pngs', [('cube_fit', ['cube_fit.png']),
                                         ('texture_fit', ['texture_fit.png', 'texture_fit_texture.png']),
                                         ('pose_fit', ['pose_fit.png']),
                                         ('ggx_fit', ['ggx_fit.png', 'ggx_fit_maps.png'])])
def test_example_runs_prints_progress_and_writes_its_images(tmp_path, name, pngs):
    result = subprocess.run([sys.executable, os.path.join(EXAMPLES, name + '.py'), '--iterations', '3', '--size', '32',
                             '--out', str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert 'iter     3/3' in result.stdout and 'it/s' in result.stdout
    for png in pngs:
        with open(tmp_path / png, 'rb') as f:
            assert f.read(8) == b'\x89PNG\r\n\x1a\n'


def test_bad_arguments_exit_with_a_message():
    result = subprocess.run([sys.executable, os.path.join(EXAMPLES, 'cube_fit.py'), '--iterations', '0'],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 2 and '--iterations must be >= 1' in result.stderr
