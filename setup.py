"""pip's build of gradraster: `pip install .`, `pip wheel .` (docs/python.md, "Installing").

The package is python/gradraster (every .py file there); its extension
gradraster._core is built by the project's own CMake, for the interpreter that
runs pip, building only the target gradraster_python and the libraries it links
(tests, benchmarks, examples and MPI off). setuptools works in build-pip/
(never the CMake build folder build/), the CMake build in
build-pip/temp.<platform>-<python>/cmake, kept between runs so a second
install rebuilds only what changed.

Environment:
  GRADRASTER_NATIVE=1         compile for this machine's CPU (-march=native);
                              default 0: a wheel that runs on any x86-64 (same results, slower)
  CMAKE_ARGS="-D..."          more CMake arguments, e.g. -DGRADRASTER_WITH_VULKAN=OFF
  CMAKE_BUILD_PARALLEL_LEVEL  build jobs (default: all CPUs)
ccache is the compiler launcher when installed (unless CMAKE_ARGS names one).
"""
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, find_packages, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
BUILD_BASE = 'build-pip'  # relative: pip runs this file in the source folder


def project_version():
    """The one version: `project(gradraster VERSION x.y)` in CMakeLists.txt."""
    match = re.search(r'project\(\s*gradraster\s+VERSION\s+([0-9][0-9.]*)', (ROOT / 'CMakeLists.txt').read_text())
    if not match:
        raise RuntimeError('CMakeLists.txt: no "project(gradraster VERSION x.y ...)"')
    return match.group(1)


def env_flag(name, default):
    value = os.environ.get(name, default)
    if value not in ('0', '1'):
        raise RuntimeError(f'{name} must be 0 or 1, got {value!r}')
    return value == '1'


class CMakeBuild(build_ext):
    """Builds gradraster._core with CMake and copies it where setuptools packs it."""

    def build_extension(self, ext):
        cmake = shutil.which('cmake')
        if cmake is None:
            raise RuntimeError('gradraster: cmake not found (Debian: apt-get install cmake; scripts/setup.sh '
                               'installs every build dependency)')
        build_dir = Path(self.build_temp).resolve() / 'cmake'
        extra = shlex.split(os.environ.get('CMAKE_ARGS', ''))
        args = [
            f'-DPython3_EXECUTABLE={sys.executable}',
            '-DCMAKE_BUILD_TYPE=Release',
            f'-DGRADRASTER_NATIVE={"ON" if env_flag("GRADRASTER_NATIVE", "0") else "OFF"}',
            '-DGRADRASTER_WITH_PYTHON=ON',
            '-DGRADRASTER_BUILD_TESTS=OFF', '-DGRADRASTER_BUILD_BENCH=OFF', '-DGRADRASTER_BUILD_EXAMPLES=OFF',
            '-DGRADRASTER_WITH_MPI=OFF',
        ]
        if shutil.which('ccache') and not any('COMPILER_LAUNCHER' in a for a in extra):
            args.append('-DCMAKE_CXX_COMPILER_LAUNCHER=ccache')
        subprocess.run([cmake, '-S', str(ROOT), '-B', str(build_dir), *args, *extra], check=True)
        if not (build_dir / 'python' / 'CMakeFiles' / 'gradraster_python.dir').is_dir():
            raise RuntimeError(f'gradraster: CMake found no Python development files or pybind11 for {sys.executable} '
                               '(Debian: apt-get install python3-dev pybind11-dev); see its messages above')
        jobs = os.environ.get('CMAKE_BUILD_PARALLEL_LEVEL') or str(os.cpu_count() or 1)
        subprocess.run([cmake, '--build', str(build_dir), '--target', 'gradraster_python', '-j', jobs], check=True)

        dest = Path(self.get_ext_fullpath(ext.name))
        built = build_dir / 'python' / 'gradraster' / dest.name
        if not built.is_file():
            raise RuntimeError(f'gradraster: CMake built no {built} (a module for another Python?)')
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, dest)


os.makedirs(BUILD_BASE, exist_ok=True)  # egg_info wants its folder to exist
setup(
    version=project_version(),
    packages=find_packages('python'),
    package_dir={'': 'python'},
    ext_modules=[Extension('gradraster._core', sources=[])],
    cmdclass={'build_ext': CMakeBuild},
    # Not build/: that is the CMake build folder of scripts/setup.sh and the
    # README. The metadata (egg-info) goes there too, not into python/.
    options={'build': {'build_base': BUILD_BASE}, 'egg_info': {'egg_base': BUILD_BASE}},
    zip_safe=False,
)
