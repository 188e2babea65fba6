"""gradraster: a deterministic, multi-threaded CPU differentiable rasterizer.

`import gradraster.torch as dr` gives nvdiffrast.torch's interface on the CPU
(docs/python.md). `write_png(path, image)` writes an image for inspection.
"""
from ._core import __version__  # the CMake project VERSION, compiled into the module


def write_png(path, image):
    """Write `image` ([H, W] or [H, W, C] with C in 1..4, values in [0, 1],
    row 0 the top row of the file) as an 8-bit PNG, atomically: the file is
    complete or untouched. Accepts a torch tensor or a numpy array."""
    import numpy as np
    from . import _core
    a = np.asarray(image.detach().cpu() if hasattr(image, 'detach') else image, dtype=np.float32)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not 1 <= a.shape[2] <= 4 or a.shape[0] < 1 or a.shape[1] < 1:
        raise ValueError(f"write_png: 'image' must be [H, W] or [H, W, C] with C in 1..4, got shape {list(a.shape)}")
    if not (a.flags.c_contiguous and a.flags.writeable):  # numpy exports DLPack from writeable arrays only
        a = np.array(a, order='C')
    _core.write_png(str(path), a)
