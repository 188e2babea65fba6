"""The package's version and the torch versions it accepts (docs/python.md,
"Installing"): gradraster.__version__ is the CMake project VERSION, the one
pip's metadata gets (setup.py reads the same line), and gradraster.torch
refuses a torch older than 1.13 with an ImportError naming both versions."""
import re
import subprocess
import sys
from pathlib import Path

import pytest

import gradraster

ROOT = Path(__file__).resolve().parents[2]


def test_the_version_is_the_cmake_project_version():
    cmake = (ROOT / 'CMakeLists.txt').read_text()
    version = re.search(r'project\(\s*gradraster\s+VERSION\s+([0-9.]+)', cmake).group(1)
    assert gradraster.__version__ == version
    assert gradraster._core.__version__ == version


# gradraster.torch imported under a stand-in torch module with the given version.
IMPORT_UNDER = """
import sys, types
fake = types.ModuleType('torch')
fake.__version__ = sys.argv[1]
sys.modules['torch'] = fake
import gradraster.torch
"""


def import_under_torch(version):
    return subprocess.run([sys.executable, '-c', IMPORT_UNDER, version], capture_output=True, text=True)


@pytest.mark.parametrize('version', ['1.12.1', '1.9.0+cpu', '0.4.1', 'unknown'])
def test_a_torch_older_than_1_13_is_refused_naming_the_supported_range(version):
    result = import_under_torch(version)
    assert result.returncode != 0
    assert f'ImportError: gradraster.torch needs torch >= 1.13, found torch {version}' in result.stderr


@pytest.mark.parametrize('version', ['1.13.0a0+gitunknown', '1.13.1', '2.3.0+cpu', '10.0'])
def test_torch_1_13_and_later_pass_the_version_check(version):
    # The stand-in has no torch.autograd, so the import fails after the check.
    result = import_under_torch(version)
    assert 'needs torch >= 1.13' not in result.stderr
    assert "No module named 'torch.autograd'" in result.stderr
