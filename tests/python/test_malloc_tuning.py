"""Importing gradraster.torch tunes glibc's malloc to keep freed memory
(docs/performance.md, "Memory"); GRADRASTER_MALLOC_DEFAULTS=1 keeps glibc's
defaults. Either way a texture fit step gives the same result."""
import os
import platform
import subprocess
import sys

import pytest

# A fit step through every op the earth-like benchmark uses (texture-sized
# gradients above glibc's 32 MiB mmap ceiling); prints the tuning and a checksum.
STEP = """
import torch
import gradraster.torch as dr
from gradraster import _core
tex = torch.full((1, 2048, 2048, 3), 0.5).requires_grad_(True)
pos = torch.tensor([[[-0.9, -0.9, 0, 1], [0.9, -0.9, 0, 1], [-0.9, 0.9, 0, 1], [0.9, 0.9, 0, 1]]])
tri = torch.tensor([[0, 1, 2], [1, 3, 2]], dtype=torch.int32)
uv = torch.tensor([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]])
opt = torch.optim.Adam([tex], lr=0.1)
for _ in range(2):
    rast, db = dr.rasterize(dr.RasterizeCpuContext(), pos, tri, (64, 64))
    texc, texd = dr.interpolate(uv, rast, tri, db, diff_attrs='all')
    loss = dr.texture(tex, texc, texd, filter_mode='linear-mipmap-linear').square().mean()
    opt.zero_grad()
    loss.backward()
    opt.step()
print(_core.keep_freed_memory(), repr(tex.detach().double().sum().item()))
"""


def start_step(defaults):
    env = {k: v for k, v in os.environ.items() if k != 'GRADRASTER_MALLOC_DEFAULTS'}
    if defaults is not None:
        env['GRADRASTER_MALLOC_DEFAULTS'] = defaults
    return subprocess.Popen([sys.executable, '-c', STEP], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def outcome(process):
    out, err = process.communicate(timeout=300)
    assert process.returncode == 0, err
    tuned, checksum = out.split()
    return tuned == 'True', checksum


@pytest.fixture(scope='module')
def outcomes():
    """(tuned?, texture checksum) as shipped, with GRADRASTER_MALLOC_DEFAULTS=1 and =0 (run side by side)."""
    started = {name: start_step(value) for name, value in (('tuned', None), ('defaults', '1'), ('other', '0'))}
    return {name: outcome(process) for name, process in started.items()}


def test_the_import_tunes_malloc_unless_the_environment_asks_for_the_defaults(outcomes):
    # Sanitizer runtimes ignore mallopt: there nothing is tuned either way.
    sanitized = 'asan' in os.environ.get('LD_PRELOAD', '')
    assert outcomes['tuned'][0] == (platform.libc_ver()[0] == 'glibc' and not sanitized)
    assert outcomes['other'][0] == outcomes['tuned'][0]  # only '1' opts out
    assert outcomes['defaults'][0] is False


def test_a_fit_step_gives_the_same_texture_with_and_without_the_tuning(outcomes):
    assert outcomes['tuned'][1] == outcomes['defaults'][1] == outcomes['other'][1]
