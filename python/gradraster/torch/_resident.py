"""The G-buffers a RasterizeVulkanContext's rasterize kept on its device, and
when a later op may read them there instead of uploading its tensors.

rasterize on a Vulkan context makes each image's G-buffer on the device,
downloads rast and rast_db once and keeps the device's copy: one handle per
image (_core.DeviceGBuffers; the backend's pool may let a copy go, and a call
on it then uploads). interpolate and antialias pass the handles on only while
the tensors they read are the very ones rasterize made or read (rast,
rast_db, pos, tri), not written in place since (torch's version counter);
otherwise none, and the device uploads the host's tensors, so results never
depend on residency. Each backward passes what its forward did: autograd
refuses saved tensors written in place since the forward. Writes torch does
not count (through .data or a numpy view) are not seen, as autograd does not
see them (docs/python.md, "Vulkan").
"""
import weakref


class KeptGBuffers:
    """A rasterize call's handles and the tensors (by name) they equal."""

    def __init__(self, handles, **tensors):
        self.handles = handles
        self._made = {name: (weakref.ref(t), t._version) for name, t in tensors.items()}

    def handles_for(self, **tensors):
        """The handles if each tensor given (None: one the call does not read) is the very one of its name,
        unwritten since; else None."""
        for name, t in tensors.items():
            if t is None:
                continue
            made, version = self._made[name]
            if made() is not t or t._version != version:
                return None
        return self.handles
