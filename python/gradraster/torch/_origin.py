"""Which context made a tensor: the rule by which interpolate, antialias and
texture (which take no context, as in nvdiffrast) find the device to run on.

rasterize (and DepthPeeler.rasterize_next_layer) records its context for the
rast it returns, with the G-buffers it kept on the device (_resident.py);
interpolate passes rast's context on to its two outputs. Only those very
tensor objects carry it: a slice, a copy, a detached alias or anything torch
computes from them is another object, which carries none (its ops then run
on the CPU kernels). docs/python.md, "Vulkan".

The record is a table keyed by the tensor object (held weakly), not an
attribute on the tensor, so that copying, pickling or torch.save of a tensor
never meets a context object (which cannot be copied or saved).
"""
import weakref

_ORIGIN = {}  # id(tensor) -> (weak reference to the tensor, its context, its KeptGBuffers or None)


def record_origin(tensor, context, kept=None):
    """Remember that `context` made `tensor` (until the tensor is freed), and
    `kept` (a _resident.KeptGBuffers, or None): the device's copy of it."""
    key = id(tensor)

    def forget(ref, key=key):
        if _ORIGIN.get(key, (None,))[0] is ref:
            del _ORIGIN[key]

    _ORIGIN[key] = (weakref.ref(tensor, forget), context, kept)
    return tensor


def _entry(tensor):
    entry = _ORIGIN.get(id(tensor))
    return entry if entry is not None and entry[0]() is tensor else None


def origin(tensor):
    """The context that made `tensor` (record_origin), or None."""
    entry = _entry(tensor)
    return entry[1] if entry else None


def kept_gbuffers(tensor):
    """The KeptGBuffers recorded with `tensor` (a rast from a Vulkan context), or None."""
    entry = _entry(tensor)
    return entry[2] if entry else None
