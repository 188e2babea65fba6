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
refuses saved tensors written in place since the forward. Inference tensors,
which have no version counter, are compared by a fingerprint of their bytes.
For other G-buffer tensors, writes torch does not count (through .data or a
numpy view) are not seen, as autograd does not see them (docs/python.md,
"Vulkan"); textures, kept across
calls and so across such writes (an optimizer loop's `tex.data -= lr *
tex.grad`), also compare a fingerprint of their bytes (KeptTextures).
"""
import threading
import weakref

from ._versions import version


class KeptGBuffers:
    """A rasterize call's handles and the tensors (by name) they equal.

    An inference tensor has no version counter (_versions.py): its bytes' fingerprint (`fingerprint`, taken
    when kept and at each later call) stands in for it, so an inference-mode render reads the device's copy too,
    and a write to it is still seen. A non-contiguous inference tensor is never matched (the device uploads)."""

    def __init__(self, handles, fingerprint, **tensors):
        self.handles = handles
        self._fingerprint = fingerprint
        self._made = {name: (weakref.ref(t), version(t), self._print(t)) for name, t in tensors.items()}

    def _print(self, t):
        """The fingerprint of an inference tensor's bytes (None for others, and where it cannot be taken)."""
        return self._fingerprint(t) if version(t) is None and t.is_contiguous() else None

    def handles_for(self, **tensors):
        """The handles if each tensor given (None: one the call does not read) is the very one of its name,
        unwritten since (its version, or for an inference tensor its fingerprint); else None."""
        for name, t in tensors.items():
            if t is None:
                continue
            made, made_version, made_print = self._made[name]
            if made() is not t or version(t) != made_version:
                return None
            if made_version is None and (made_print is None or self._print(t) != made_print):
                return None
        return self.handles


class KeptTextures:
    """The handles of the textures a RasterizeVulkanContext's texture calls kept on its device
    (_core.DeviceTextures), found again by the tensors they were made from, so that later calls on the same
    texture (several views per iteration, a fixed environment map over many iterations) read the device's copy
    instead of uploading it.

    A call finds a texture's handles only while its tensors (tex, and a prebuilt or user mip stack) are the very
    objects of the call that kept them, not written in place since (torch's version counter: an optimizer step or
    any in-place op bumps it), with the same bytes (a 64-bit fingerprint of each tensor, recorded when kept: it
    sees the writes torch does not count, through .data or a numpy view), and read alike (cube or 2D, the same
    levels); otherwise it passes none, and the device uploads: results never depend on residency. The
    fingerprint costs one pass over the texels per call (docs/gpu.md, "What stays resident"). At most `capacity`
    textures, the least recently used forgotten first (the device bounds its own copies, and may let one go: the
    handle then only costs an upload).

    `fingerprint(tensor)`: the fingerprint of a contiguous tensor's bytes (_core.fingerprint; the texture
    tensors are contiguous, texture() checks)."""

    def __init__(self, capacity, fingerprint):
        self.capacity = capacity
        self._fingerprint = fingerprint
        self._entries = []  # (how read, [(weak reference, version, fingerprint)], handles); most recently used last
        self._lock = threading.RLock()

    def __len__(self):
        return len(self._entries)

    def texels(self, tensors):
        """`tensors` (a list) as find and keep take them: their fingerprints computed once, when first needed."""
        return Texels(tensors, self._fingerprint)

    @staticmethod
    def _same_objects(refs, tensors):
        return len(refs) == len(tensors) and all(
            ref() is t and version(t) == made for (ref, made, _), t in zip(refs, tensors))

    @staticmethod
    def _same(refs, texels):
        return KeptTextures._same_objects(refs, texels.tensors) and [
            p for _, _, p in refs] == texels.fingerprints()

    def find(self, how, texels):
        """The handles kept for `texels` (a Texels) read `how` (a hashable description), or None."""
        with self._lock:  # the fingerprint lets the GIL go: another thread may keep meanwhile
            for k, (key, refs, handles) in enumerate(self._entries):
                if key == how and self._same(refs, texels):
                    self._entries.append(self._entries.pop(k))
                    return handles
        return None

    def keep(self, how, texels, handles):
        """Remember `handles` (None: forget) for `texels` read `how`, as they are now."""
        with self._lock:
            # Forget the entry of these very objects read alike (whatever their bytes were), and the dead ones.
            self._entries = [e for e in self._entries
                             if not (e[0] == how and self._same_objects(e[1], texels.tensors))
                             and all(r() is not None for r, _, _ in e[1])]
            if handles is None or self.capacity < 1:
                return
            prints = texels.fingerprints()
            self._entries.append((how, [(weakref.ref(t), version(t), p) for t, p in zip(texels.tensors, prints)],
                                  handles))
            del self._entries[:-self.capacity]


class Texels:
    """A texture call's tensors and their fingerprints, computed at most once per call: find computes them only
    when an entry holds these very objects, keep reuses them (nothing writes the texels in between: the call
    reads them)."""

    def __init__(self, tensors, fingerprint):
        self.tensors = tensors
        self._fingerprint = fingerprint
        self._prints = None

    def fingerprints(self):
        if self._prints is None:
            self._prints = [self._fingerprint(t) for t in self.tensors]
        return self._prints
