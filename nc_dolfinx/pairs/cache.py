"""What a mesh's pairs keep between binds: the faces and the projections between them.

A load path binds the problem again at every increment (c_n, μ and the offset may be expressions of the
path's parameters), and a new :class:`~.coupling.PairCoupling` is made for each; the faces, their cut
integration points and the closest points on the other face depend on the mesh alone, and they are the
set-up's costly part (the searches; in 3D the clipping). They are kept per mesh (weakly: gone with the mesh)
and per its coordinates (a fingerprint of this rank's geometry, so that a mesh moved in place is searched
again), and reused when every rank has them.
"""
import hashlib
import weakref

from mpi4py import MPI

_KEPT = weakref.WeakKeyDictionary()  # mesh -> {(fingerprint, key): value}


def kept(mesh, key, make):
    """``make()``'s value for ``mesh`` and ``key``, made once (collectively: made again on every rank unless
    every rank has it)."""
    store = _KEPT.setdefault(mesh, {})
    full = (hashlib.blake2b(mesh.geometry.x.tobytes(), digest_size=16).digest(), key)
    if not mesh.comm.allreduce(full in store, op=MPI.LAND):
        store[full] = make()
    return store[full]
