"""The G-buffers a RasterizeVulkanContext's rasterize kept on its device (and
the textures its texture calls kept: KeptTextures below), and when a later op
may read them there instead of uploading its tensors.

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


class KeptTextures:
    """The handles of the textures a RasterizeVulkanContext's texture calls kept on its device
    (_core.DeviceTextures), found again by the tensors they were made from, so that later calls on the same
    texture (several views per iteration, a fixed environment map over many iterations) read the device's copy
    instead of uploading it.

    A call finds a texture's handles only while its tensors (tex, and a prebuilt or user mip stack) are the very
    objects of the call that kept them, not written in place since (torch's version counter: an optimizer step or
    any in-place op bumps it; writes through .data or a numpy view do not, as autograd does not see them), and
    read alike (cube or 2D, the same levels); otherwise it passes none, and the device uploads: results never
    depend on residency. At most `capacity` textures, the least recently used forgotten first (the device bounds
    its own copies, and may let one go: the handle then only costs an upload)."""

    def __init__(self, capacity):
        self.capacity = capacity
        self._entries = []  # (how read, [(weak reference, version)], handles); most recently used last

    def __len__(self):
        return len(self._entries)

    @staticmethod
    def _same(refs, tensors):
        return len(refs) == len(tensors) and all(
            ref() is t and t._version == version for (ref, version), t in zip(refs, tensors))

    def find(self, how, tensors):
        """The handles kept for `tensors` (a list) read `how` (a hashable description), or None."""
        for k, (key, refs, handles) in enumerate(self._entries):
            if key == how and self._same(refs, tensors):
                self._entries.append(self._entries.pop(k))
                return handles
        return None

    def keep(self, how, tensors, handles):
        """Remember `handles` (None: forget) for `tensors` read `how`, as they are now."""
        self._entries = [e for e in self._entries
                         if not (e[0] == how and self._same(e[1], tensors)) and all(r() is not None for r, _ in e[1])]
        if handles is None or self.capacity < 1:
            return
        self._entries.append((how, [(weakref.ref(t), t._version) for t in tensors], handles))
        del self._entries[:-self.capacity]
