"""torch's count of a tensor's in-place writes (its version counter), by which
the tables that find kept things again by tensor (_resident.py,
_topologies.py) and the DepthPeeler see writes.

A tensor made under torch.inference_mode() (an inference tensor) has no
counter: reading t._version raises there. version() gives None for it, and
each caller then relies on a fingerprint of the bytes: the tables of textures
and topologies on the one they compare anyway, the peeler and the kept
G-buffers on one they take for inference tensors only.
"""


def version(t):
    """t._version, or None for an inference tensor, whose writes torch does not count."""
    return None if t.is_inference() else t._version
