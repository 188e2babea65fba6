"""gradraster: a deterministic, multi-threaded CPU differentiable rasterizer.

`import gradraster.torch as dr` gives nvdiffrast.torch's interface on the CPU
(docs/python.md).
"""
__version__ = '0.1'
