"""The edge topologies antialias and visibility_antialias built for themselves
(no topology_hash given), found again by the tri tensor they were built from,
so that a program calling antialias every iteration on the same mesh (as
nvdiffrast programs do, without a topology_hash) builds it once.

The adjacency depends on tri's indices alone (python/src/antialias.cpp,
raster::build_edge_topology: not on pos, nor on its vertex count), so it is
reused while tri is unchanged: the very object (held weakly, by a table here,
never an attribute on the tensor), not written in place since (torch's
version counter; an inference tensor has none: _versions.py), with the same shape, dtype and data pointer, and the same
bytes (a 64-bit fingerprint, as KeptTextures in _resident.py: it sees the
writes torch does not count, through .data or a numpy view). Otherwise it is
built again: results never depend on the table. The fingerprint costs one
pass over tri per call (much less than building the adjacency).

A kept topology (_core.Topology) is immutable and names itself on a Vulkan
device by a serial (raster::EdgeTopology), so the device keeps its copy of it
across calls too (docs/gpu.md, "What stays resident").
"""
import threading
import weakref

from ._versions import version


class KeptTopologies:
    """At most `capacity` topologies, the least recently used forgotten first (and each as soon as its tri is
    freed). `fingerprint(tensor)`: the fingerprint of a contiguous tensor's bytes (_core.fingerprint).
    Thread-safe: the fingerprint lets the GIL go, so the table is locked around find and keep."""

    def __init__(self, capacity, fingerprint):
        self.capacity = capacity
        self._fingerprint = fingerprint
        # [weak reference to tri, (version, shape, dtype, data pointer), fingerprint, topology]; most recently
        # used last. Only ever replaced, never changed in place: a weak reference's callback may run mid-find.
        self._entries = []
        self._lock = threading.RLock()

    def __len__(self):
        return len(self._entries)

    @staticmethod
    def _state(tri):
        return version(tri), tuple(tri.shape), tri.dtype, tri.data_ptr()

    def find(self, tri):
        """The topology kept for `tri` as it is now, or None."""
        with self._lock:
            entries = self._entries
            for entry in entries:
                ref, state, print_, topology = entry
                if ref() is tri and state == self._state(tri) and print_ == self._fingerprint(tri):
                    self._entries = [e for e in self._entries if e is not entry] + [entry]
                    return topology
        return None

    def keep(self, tri, print_, state, topology):
        """Remember `topology`, built from `tri` when its fingerprint was `print_` and _state `state` (taken
        before the build), in place of what was kept for it."""
        if self.capacity < 1:
            return
        with self._lock:
            ref = weakref.ref(tri, self._forget)
            kept = [e for e in self._entries if e[0]() is not tri and e[0]() is not None]
            self._entries = (kept + [[ref, state, print_, topology]])[-self.capacity:]

    def _forget(self, ref):
        with self._lock:
            self._entries = [e for e in self._entries if e[0] is not ref]

    def built(self, tri, build):
        """build() (which checks tri and may raise: nothing is kept then), kept for `tri` as it is now."""
        state, print_ = self._state(tri), self._fingerprint(tri)  # before the build: a write during it is seen
        topology = build()
        self.keep(tri, print_, state, topology)
        return topology
