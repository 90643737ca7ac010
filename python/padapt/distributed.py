"""padapt.DistributedMesh: a mesh distributed over the ranks of an mpi4py
communicator (the C pa_dmesh), with its values and halo exchanges as numpy
arrays, and the parallel adaptation.

Run under `mpiexec -n P python3 script.py`. Every method marked collective
must be called by every rank of the communicator, in the same order.
Importing this module imports mpi4py, which initialises MPI.

Local numbering of each entity kind: the owned entities first, [0, nowned),
then the ghosts, [nowned, nlocal). Arrays handed out (global ids, owners,
value data, the local mesh's arrays) are views of the library's storage and
stay valid until the distribution changes (adapt, redistribute,
rebalance, reorder): fetch them again afterwards. A local_mesh or Value
object used after such a change raises RuntimeError instead of reading
freed memory.
"""
import ctypes
import os

import numpy as np
from mpi4py import MPI

from . import _lib
from ._lib import lib, check
from .mesh import Mesh, as_metric, as_field, stats_dict
from .adapt import Report, fidelity_dict, transfer_dict, describe, remesh_options
from .metric import _RECOVERY_NAME

__all__ = ["DistributedMesh", "Value", "KINDS"]

#: entity kinds, by name, as pa_entity
KINDS = {"vertex": 0, "element": 1, "boundary": 2, "edge": 3}
_SETS = {"owned": 0, "ghost": 1, "local": 2, "interior": 3, "frontier": 4}


def _handle_type(cls):
    # Open MPI handles are pointers, MPICH's are ints.
    return ctypes.c_int if MPI._sizeof(cls) == ctypes.sizeof(ctypes.c_int) else ctypes.c_void_p


c_comm, c_type, c_op = _handle_type(MPI.Comm), _handle_type(MPI.Datatype), _handle_type(MPI.Op)
P, PP, S, I, X = ctypes.c_void_p, ctypes.POINTER(ctypes.c_void_p), ctypes.c_int, ctypes.c_int, _lib.c_idx
for _n, _r, _a in [
        ("pa_dmesh_distribute", S, [c_comm, I, P, I, PP]),
        ("pa_dmesh_read", S, [c_comm, ctypes.c_char_p, I, PP]),
        ("pa_dmesh_write", S, [P, ctypes.c_char_p]),
        ("pa_dmesh_gather", S, [P, I, PP]), ("pa_dmesh_destroy", None, [P]),
        ("pa_dmesh_dim", I, [P]), ("pa_dmesh_overlap", I, [P]),
        ("pa_dmesh_nowned", X, [P, I]), ("pa_dmesh_nlocal", X, [P, I]),
        ("pa_dmesh_nglobal", _lib.c_gid, [P, I]), ("pa_dmesh_gids", P, [P, I]),
        ("pa_dmesh_owners", P, [P, I]), ("pa_dmesh_elem_layers", P, [P]),
        ("pa_dmesh_neighbours", I, [P, ctypes.POINTER(ctypes.POINTER(ctypes.c_int))]),
        ("pa_dmesh_mesh", P, [P]), ("pa_dmesh_sync_mesh", S, [P]),
        ("pa_dmesh_memory_used", ctypes.c_size_t, [P]),
        ("pa_dmesh_value_add", S, [P, I, ctypes.c_char_p, c_type, I, ctypes.c_int32, PP]),
        ("pa_dmesh_value_find", P, [P, ctypes.c_char_p]),
        ("pa_dmesh_value_remove", S, [P, P]),
        ("pa_dmesh_value_data", P, [P, ctypes.POINTER(X), ctypes.POINTER(X)]),
        ("pa_dmesh_value_entities", P, [P]),
        ("pa_dmesh_halo", S, [P, P]), ("pa_dmesh_halo_begin", S, [P, P]),
        ("pa_dmesh_halo_end", S, [P, P]), ("pa_dmesh_reduce", S, [P, P, c_op]),
        ("pa_dmesh_iter_init", S, [P, I, I, ctypes.POINTER(_lib.DmeshIter)]),
        ("pa_dmesh_redistribute", S, [P, ctypes.POINTER(ctypes.c_int), _lib.c_dbl_p]),
        ("pa_dmesh_rebalance", S, [P, _lib.c_dbl_p, ctypes.c_double, ctypes.POINTER(_lib.c_gid)]),
        ("pa_dmesh_reorder", S, [P]),
        ("pa_dmesh_check", S, [P]), ("pa_dmesh_checksum", S, [P, ctypes.POINTER(ctypes.c_uint64)]),
        ("pa_dmesh_partition_stats", S, [P, P, ctypes.POINTER(ctypes.c_double), ctypes.POINTER(_lib.c_gid)]),
        ("pa_dmesh_adapt", S, [P, ctypes.POINTER(_lib.AdaptOpts), ctypes.POINTER(_lib.AdaptReport)]),
        ("pa_dmesh_metric_from_hessian", S, [P, I, I, ctypes.POINTER(_lib.HessianOpts)]),
        ("pa_dmesh_metric_from_levelset", S, [P, I, ctypes.POINTER(_lib.LevelsetOpts)]),
        ("pa_dmesh_metric_complexity", S, [P, ctypes.POINTER(ctypes.c_double)]),
        ("pa_dmesh_stats", S, [P, ctypes.POINTER(_lib.Stats)]),
]:
    _lib._proto(_n, _r, *_a)

_DTYPES = {np.dtype(np.float64): MPI.DOUBLE, np.dtype(np.float32): MPI.FLOAT,
           np.dtype(np.int32): MPI.INT32_T, np.dtype(np.int64): MPI.INT64_T,
           np.dtype(np.uint8): MPI.UINT8_T}
_OPS = {"sum": MPI.SUM, "min": MPI.MIN, "max": MPI.MAX}


def _h(obj, cls):
    return cls(MPI._handleof(obj))


def _agree(comm, check_fn):
    """Run the rank-local argument check check_fn() on every rank and raise
    the same ValueError/TypeError on every rank if it failed on any, so
    that no rank enters a collective call that another has left. Returns
    check_fn()'s result."""
    try:
        out, err = check_fn(), None
    except (ValueError, TypeError) as exc:
        out, err = None, exc
    errs = comm.allgather(None if err is None else (type(err).__name__, str(err)))
    bad = [(r, e) for r, e in enumerate(errs) if e is not None]
    if bad:
        cls = TypeError if all(e[0] == "TypeError" for _, e in bad) else ValueError
        raise cls("; ".join("rank %d: %s" % (r, e[1]) for r, e in bad))
    return out


def _kind(kind):
    if kind not in KINDS:
        raise ValueError("kind: one of %s, got %r" % (", ".join(KINDS), kind))
    return KINDS[kind]


class _LocalMesh(Mesh):
    """The local mesh of a DistributedMesh (borrowed, never destroyed here)."""

    @property
    def _h(self):
        dm = self._owner
        if dm._dm is None or self._gen != dm._gen:
            raise RuntimeError("this local mesh is stale: the distribution changed "
                               "(adapt, redistribute, ...); use dm.local_mesh again")
        return self._ptr

    @_h.setter
    def _h(self, v):
        self._ptr = v

    def __del__(self):
        pass


class Value(object):
    """Values attached to the entities of one kind of a DistributedMesh:
    ncomp items of a numpy dtype per entity, following them through
    redistribution. data is a numpy view (n, ncomp) ((n,) when ncomp is 1)
    of the n local entities that hold it, the owned ones first (nowned of
    them)."""

    def __init__(self, dm, handle, name, kind, dtype, ncomp, ref):
        self._dm, self._v, self._gen = dm, ctypes.c_void_p(handle), dm._gen
        self.name, self.kind, self.dtype, self.ncomp, self.ref = name, kind, dtype, ncomp, ref

    def _handle(self):
        if self._dm._dm is None or self._v is None:
            raise RuntimeError("value %r was removed or its mesh closed" % self.name)
        return self._v

    def _counts(self):
        n, no = X(), X()
        addr = lib.pa_dmesh_value_data(self._handle(), ctypes.byref(n), ctypes.byref(no))
        return addr, n.value, no.value

    @property
    def data(self):
        """Writable numpy view of the local blocks (owned first)."""
        addr, n, _ = self._counts()
        shape = (n,) if self.ncomp == 1 else (n, self.ncomp)
        return _lib.view(self._dm, addr, shape, self.dtype)

    @property
    def owned(self):
        """The owned blocks: data[:nowned]."""
        return self.data[:self.nowned]

    @property
    def nowned(self):
        """Number of owned blocks (the first ones of data)."""
        return self._counts()[2]

    @property
    def entities(self):
        """Local entity of each block (a copy); arange(n) for a value on
        every entity of its kind."""
        addr, n, _ = self._counts()
        ent = lib.pa_dmesh_value_entities(self._handle())
        if not ent:
            return np.arange(n, dtype=np.int32)
        return _lib.view(self._dm, ent, (n,), np.int32, False).copy()

    def halo(self):
        """Owner -> ghost update: every ghost block receives its owner's.
        Collective."""
        check(lib.pa_dmesh_halo(self._dm._dm, self._handle()))

    def halo_begin(self):
        """Start halo(); work on owned data only until halo_end(). Collective."""
        check(lib.pa_dmesh_halo_begin(self._dm._dm, self._handle()))

    def halo_end(self):
        """Finish halo(). Collective."""
        check(lib.pa_dmesh_halo_end(self._dm._dm, self._handle()))

    def reduce(self, op="sum"):
        """Ghost -> owner reduction, owner = op(owner, each ghost copy), op
        "sum", "min" or "max", in rank order (independent of timing);
        ghosts are left as they are. Collective."""
        if op not in _OPS:
            raise ValueError("op: 'sum', 'min' or 'max', got %r" % (op,))
        check(lib.pa_dmesh_reduce(self._dm._dm, self._handle(), _h(_OPS[op], c_op)))

    def remove(self):
        """Detach and free the value. Collective."""
        check(lib.pa_dmesh_value_remove(self._dm._dm, self._handle()))
        self._v = None

    def __repr__(self):
        return "<padapt.Value %r on %s: %d x %s>" % (self.name, self.kind, self.ncomp, self.dtype)


class DistributedMesh(object):
    """A mesh distributed over an MPI communicator (mpi4py).

    Build one with DistributedMesh.distribute(mesh, comm) (a Mesh held by
    the root rank, partitioned with PT-Scotch) or DistributedMesh.read(path,
    comm) (a sequential file or a distributed set). Release it with close()
    (collective) or a `with` block.
    """

    def __init__(self, handle, comm):
        self._dm = handle
        self.comm = comm
        self._gen = 0
        self._values = {}

    # ------------------------------------------------------------ creation
    @classmethod
    def distribute(cls, mesh, comm=None, root=0, overlap=1):
        """Partition the Mesh held by rank root (ignored elsewhere; may be
        None there) over comm (default MPI.COMM_WORLD) with overlap ghost
        layers. Its metric and fields come along. Collective."""
        comm = MPI.COMM_WORLD if comm is None else comm

        def args():
            if not 0 <= int(root) < comm.size or int(overlap) < 0:
                raise ValueError("distribute: root in [0, %d) and overlap >= 0" % comm.size)
            if comm.rank == root and not isinstance(mesh, Mesh):
                raise TypeError("distribute: rank %d needs a padapt.Mesh" % root)
        _agree(comm, args)
        h = ctypes.c_void_p()
        st = lib.pa_dmesh_distribute(_h(comm, c_comm), int(root),
                                     mesh._h if comm.rank == root else None,
                                     int(overlap), ctypes.byref(h))
        check(st)
        return cls(h, comm)

    @classmethod
    def read(cls, path, comm=None, overlap=1):
        """Read a sequential mesh file (on rank 0, then distributed) or a
        distributed set written by write(), by any number of ranks.
        Collective."""
        comm = MPI.COMM_WORLD if comm is None else comm
        h = ctypes.c_void_p()
        check(lib.pa_dmesh_read(_h(comm, c_comm), os.fsencode(path), int(overlap), ctypes.byref(h)))
        return cls(h, comm)

    def write(self, path):
        """Write a distributed set: path "OUT.meshb" gives OUT.<rank>.meshb,
        OUT.pvtu and the manifest OUT.manifest, all or nothing. Collective."""
        check(lib.pa_dmesh_write(self._live(), os.fsencode(path)))

    def gather(self, root=0):
        """The whole mesh (numbered by global id, with metric and fields) as
        a Mesh on rank root, None elsewhere. Collective."""
        h = ctypes.c_void_p()
        check(lib.pa_dmesh_gather(self._live(), int(root), ctypes.byref(h)))
        return Mesh._wrap(h) if h else None

    def close(self):
        """Destroy the distributed mesh. Collective."""
        if self._dm is not None:
            if not MPI.Is_finalized():
                lib.pa_dmesh_destroy(self._dm)
            self._dm = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    def _live(self):
        if self._dm is None:
            raise RuntimeError("the DistributedMesh is closed")
        return self._dm

    def _changed(self):
        self._gen += 1

    # ------------------------------------------------------------- queries
    @property
    def dim(self):
        """2 (triangles) or 3 (tetrahedra)."""
        return lib.pa_dmesh_dim(self._live())

    @property
    def overlap(self):
        """Number of ghost element layers."""
        return lib.pa_dmesh_overlap(self._live())

    def nowned(self, kind="element"):
        """Owned entities of a kind ("vertex", "element", "boundary", "edge") on this rank."""
        return lib.pa_dmesh_nowned(self._live(), _kind(kind))

    def nlocal(self, kind="element"):
        """Owned + ghost entities of a kind on this rank."""
        return lib.pa_dmesh_nlocal(self._live(), _kind(kind))

    def nglobal(self, kind="element"):
        """Entities of a kind over all ranks."""
        return lib.pa_dmesh_nglobal(self._live(), _kind(kind))

    def global_ids(self, kind="vertex"):
        """(nlocal,) int64 global ids of the local entities (read-only view)."""
        k = _kind(kind)
        return _lib.view(self, lib.pa_dmesh_gids(self._live(), k), (self.nlocal(kind),), np.int64, False)

    def owners(self, kind="vertex"):
        """(nlocal,) int32 owner rank of each local entity (read-only view)."""
        k = _kind(kind)
        return _lib.view(self, lib.pa_dmesh_owners(self._live(), k), (self.nlocal(kind),), np.int32, False)

    def elem_layers(self):
        """(nlocal elements,) uint8: 0 owned, k for a ghost of layer k (read-only view)."""
        return _lib.view(self, lib.pa_dmesh_elem_layers(self._live()), (self.nlocal("element"),),
                         np.uint8, False)

    def neighbours(self):
        """Ranks this rank exchanges with (a list)."""
        p = ctypes.POINTER(ctypes.c_int)()
        n = lib.pa_dmesh_neighbours(self._live(), ctypes.byref(p))
        return [p[i] for i in range(n)]

    def entities(self, kind="element", which="owned"):
        """Local indices of a set of entities: "owned", "ghost", "local",
        "interior" (owned, no vertex shared with another rank) or
        "frontier" (owned, not interior). A new int32 array."""
        if which not in _SETS:
            raise ValueError("which: one of %s, got %r" % (", ".join(_SETS), which))
        it = _lib.DmeshIter()
        check(lib.pa_dmesh_iter_init(self._live(), _kind(kind), _SETS[which], ctypes.byref(it)))
        if not it.list:
            return np.arange(it.first, it.end, dtype=np.int32)
        return np.ctypeslib.as_array(it.list, (it.end,))[it.first:it.end].copy()

    @property
    def local_mesh(self):
        """The local mesh (owned and ghost entities, local numbering) as a
        padapt.Mesh whose arrays are views. Change only coordinates,
        references, flags, metric and fields, then call sync_mesh(). Valid
        until the distribution changes."""
        m = _LocalMesh._wrap(lib.pa_dmesh_mesh(self._live()), owner=self)
        m._gen = self._gen
        return m

    def sync_mesh(self):
        """Copy coordinates, references, flags, metric and fields of owned
        entities to their ghosts. Collective."""
        check(lib.pa_dmesh_sync_mesh(self._live()))

    def set_metric(self, values):
        """Set the metric from values for the owned vertices (nowned rows)
        or for all local vertices (nlocal rows): sizes or 3|6-component
        tensors; ghosts then receive their owners' values. Collective."""
        lm, no, nl = self.local_mesh, self.nowned("vertex"), self.nlocal("vertex")

        def args():
            v = np.asarray(values)
            if v.ndim >= 1 and v.shape[0] == no and no != nl:
                v = np.concatenate([v, np.repeat(v[:1], nl - no, axis=0)]) if no else v
            return as_metric("metric", v, self.dim, nl)
        m, nc = _agree(self.comm, args)
        check(lib.pa_mesh_set_metric(lm._h, nc, _lib.ptr(m)))
        self.sync_mesh()

    def add_field(self, name, values):
        """Attach a vertex field (owned or local rows, as set_metric),
        interpolated by adapt(). Collective."""
        lm, no, nl = self.local_mesh, self.nowned("vertex"), self.nlocal("vertex")

        def args():
            if not isinstance(name, str) or not name or len(name.encode()) >= 64:
                raise ValueError("field names must be non-empty strings of under 64 bytes: %r" % (name,))
            v = np.asarray(values)
            if v.ndim >= 1 and v.shape[0] == no and no != nl and v.dtype.kind in "fiu":
                v = np.concatenate([v, np.zeros((nl - no,) + v.shape[1:], v.dtype)])
            return as_field(name, v, nl)[0]
        lm.add_field(name, _agree(self.comm, args))
        self.sync_mesh()

    def memory_used(self):
        """Bytes used by this rank's part."""
        return lib.pa_dmesh_memory_used(self._live())

    # -------------------------------------------------------------- values
    def add_value(self, name, kind="vertex", ncomp=1, dtype="float64", ref=-1):
        """Attach a value of ncomp items of dtype (float64, float32, int32,
        int64, uint8) to every entity of a kind, or only to those of
        reference ref; initialised to zero. Returns a Value. Collective."""
        def args():
            dt = np.dtype(dtype)
            if dt not in _DTYPES:
                raise ValueError("dtype: one of %s, got %s" % (", ".join(str(d) for d in _DTYPES), dt))
            if int(ncomp) < 1:
                raise ValueError("ncomp: expected >= 1, got %r" % (ncomp,))
            if not isinstance(name, str) or not name:
                raise ValueError("name: a non-empty string")
            _kind(kind)
            return dt
        dtype = _agree(self.comm, args)
        v = ctypes.c_void_p()
        check(lib.pa_dmesh_value_add(self._live(), _kind(kind), name.encode(),
                                     _h(_DTYPES[dtype], c_type), int(ncomp), int(ref),
                                     ctypes.byref(v)))
        return Value(self, v.value, name, kind, dtype, int(ncomp), int(ref))

    # ------------------------------------------------------- distribution
    def redistribute(self, newpart=None, weights=None):
        """Move owned elements to the ranks newpart ((nowned elements,)
        ints), or repartition with PT-Scotch when None (weights: one per
        owned element). Collective; invalidates views."""
        ne = self.nowned("element")

        def args():
            part = wts = None
            if newpart is not None:
                a = np.asarray(newpart)
                if a.dtype.kind not in "iu" or a.shape != (ne,) or \
                        (ne and (a.min() < 0 or a.max() >= self.comm.size)):
                    raise ValueError("newpart: (%d,) integer ranks in [0, %d)" % (ne, self.comm.size))
                part = np.ascontiguousarray(a, dtype=np.int32)
            if weights is not None:
                from .mesh import as_float
                wts = as_float("weights", weights, (ne,))
            return part, wts
        part, wts = _agree(self.comm, args)
        p = None if part is None else part.ctypes.data_as(ctypes.POINTER(ctypes.c_int))
        w = None if wts is None else _lib.ptr(wts)
        self._changed()
        check(lib.pa_dmesh_redistribute(self._live(), p, w))

    def rebalance(self, tol=_lib.ADAPT_DEFAULTS.rebalance_tol):
        """Even out the owned elements when a rank holds more than tol times
        the mean. Returns the number of elements moved (-1 after a full
        repartition). Collective; invalidates views."""
        n = _lib.c_gid()
        self._changed()
        check(lib.pa_dmesh_rebalance(self._live(), None, float(tol), ctypes.byref(n)))
        return n.value

    def reorder(self):
        """Renumber owned and ghost entities for locality (elements along
        the Hilbert curve, the other kinds following them); values, ids and
        owners follow. Collective; invalidates views."""
        self._changed()
        check(lib.pa_dmesh_reorder(self._live()))

    def check(self):
        """Check the distributed mesh (ids, ghosts equal owners, conformity
        across ranks, orientation); raise padapt.Error on every rank.
        Collective."""
        check(lib.pa_dmesh_check(self._live()))

    def checksum(self):
        """A checksum of the mesh and its values independent of the number
        of ranks and of the numbering. Collective."""
        c = ctypes.c_uint64()
        check(lib.pa_dmesh_checksum(self._live(), ctypes.byref(c)))
        return c.value

    def partition_stats(self):
        """(owned elements per rank, imbalance max/mean, edge cut). Collective."""
        n = np.zeros(self.comm.size, np.int64)
        imb, cut = ctypes.c_double(), _lib.c_gid()
        check(lib.pa_dmesh_partition_stats(self._live(), n.ctypes.data, ctypes.byref(imb), ctypes.byref(cut)))
        return n, imb.value, cut.value

    def stats(self):
        """Statistics of the whole mesh (as Mesh.stats of the gathered
        mesh), the same dict on every rank. Collective."""
        s = _lib.Stats()
        check(lib.pa_dmesh_stats(self._live(), ctypes.byref(s)))
        return stats_dict(s)

    # ------------------------------------------------------------- metrics
    def _field_index(self, name):
        names = list(self.local_mesh.fields)
        if name not in names:
            raise KeyError("no vertex field %r (fields: %s)" % (name, ", ".join(names) or "none"))
        return names.index(name)

    def metric_from_hessian(self, field, comp=0, *, target=None, err=None,
                            p=_lib.HESSIAN_DEFAULTS.p, hmin=None, hmax=None,
                            hgrad=_lib.HESSIAN_DEFAULTS.hgrad,
                            recovery=_RECOVERY_NAME[_lib.HESSIAN_DEFAULTS.recovery]):
        """Set the metric to the Hessian metric of component comp of vertex
        field `field` (see padapt.metric.hessian); needs overlap >= 2.
        Collective."""
        from .metric import _hessian_opts
        o = _hessian_opts("metric_from_hessian", target, err, p, hmin, hmax, hgrad,
                          recovery)
        check(lib.pa_dmesh_metric_from_hessian(self._live(), self._field_index(field), int(comp),
                                               ctypes.byref(o)))

    def metric_from_levelset(self, field, *, eps, hmin, hmax, band=None,
                             hgrad=_lib.LEVELSET_DEFAULTS.hgrad):
        """Set the metric to the level-set metric of the scalar vertex field
        `field` (see padapt.metric.levelset); needs overlap >= 2. Collective."""
        from .metric import _opt
        o = _lib.LevelsetOpts()
        lib.pa_metric_levelset_opts_default(ctypes.byref(o))
        o.eps, o.hmin, o.hmax = _opt("eps", eps, True), _opt("hmin", hmin, True), _opt("hmax", hmax, True)
        if band is not None:
            o.band = _opt("band", band, True)
        o.hgrad = -1.0 if hgrad is None else _opt("hgrad", hgrad)
        check(lib.pa_dmesh_metric_from_levelset(self._live(), self._field_index(field), ctypes.byref(o)))

    def metric_complexity(self):
        """Complexity of the metric over the whole mesh. Collective."""
        c = ctypes.c_double()
        check(lib.pa_dmesh_metric_complexity(self._live(), ctypes.byref(c)))
        return c.value

    # --------------------------------------------------------------- adapt
    def adapt(self, *, hsiz=None, hmin=None, hmax=None, hgrad=None, hausd=None,
              max_iter=None, pieces_per_rank=None, mem_mb=None, check_pieces=None,
              rebalance=None, geometry=None, **options):
        """Adapt in place to the metric (set_metric, metric_from_hessian,
        ...) or to hsiz, by the parallel piece loop of pa_dmesh_adapt; vertex
        fields are interpolated. Options as padapt.adapt, plus max_iter,
        pieces_per_rank, mem_mb (memory bound per rank), check_pieces
        (True/False), rebalance (True/False), geometry (a padapt.Geometry
        loaded on every rank, for a mesh distributed from a classified
        one). Returns a Report with the
        members of `mpiexec padapt adapt -json` (the same on every rank).
        Collective; invalidates views. The GIL is released meanwhile."""
        def args():
            o = _lib.AdaptOpts()
            lib.pa_adapt_opts_default(ctypes.byref(o))
            remesh_options(o.remesh, hsiz=hsiz, hmin=hmin, hmax=hmax, hgrad=hgrad, hausd=hausd,
                           **options)
            for k, v in (("max_iter", max_iter), ("pieces_per_rank", pieces_per_rank),
                         ("check_pieces", check_pieces), ("rebalance", rebalance)):
                if v is not None:
                    setattr(o, k, int(v))
            if mem_mb is not None:
                o.mem_mb = float(mem_mb)
            if geometry is not None:
                from .geometry import Geometry
                if not isinstance(geometry, Geometry):
                    raise TypeError("adapt: geometry must be a padapt.Geometry")
                o.remesh.geometry = geometry._h
            if hsiz is not None and o.remesh.hsiz <= 0:
                raise ValueError("hsiz: expected a positive size, got %r" % (hsiz,))
            if o.remesh.hsiz <= 0 and lib.pa_mesh_metric_ncomp(self.local_mesh._h) == 0:
                raise ValueError("adapt: no metric: set one (set_metric, metric_from_hessian) "
                                 "or give hsiz=")
            return o
        o = _agree(self.comm, args)
        before = (self.nglobal("element"), self.nglobal("vertex"))
        r = _lib.AdaptReport()
        self._changed()
        check(lib.pa_dmesh_adapt(self._live(), ctypes.byref(o), ctypes.byref(r)))
        stats = r.fidelity.user if r.fidelity.measured else None
        if stats is None:
            stats = _lib.Stats()
            check(lib.pa_dmesh_stats(self._live(), ctypes.byref(stats)))
        mine = (lib.pa_memory_peak(), lib.pa_peak_rss())
        allm = self.comm.allgather(mine)
        d = stats_dict(stats)
        d.update({
            "processes": self.comm.size, "remesher": "builtin", "time_s": r.time_total,
            "time_x_processes_s": r.time_total * self.comm.size, "iterations": r.niter,
            "converged": bool(r.converged), "stalled": bool(r.stalled), "pieces": r.npieces,
            "pieces_rolled_back": r.nfailed, "elements_before": before[0],
            "vertices_before": before[1], "bytes_moved": r.bytes_moved,
            "remesh_busy_s": r.remesh_busy, "remesh_cpu_s": r.remesh_cpu,
            "nsplit": r.nsplit, "ncollapse": r.ncollapse, "nswap": r.nswap,
            "nmove": r.nmove,
            "steps_s": {"tag": r.t_tag, "pieces": r.t_pieces, "gather": r.t_gather,
                        "remesh": r.t_remesh, "reintegrate": r.t_reintegrate,
                        "rebalance": r.t_rebalance, "measure": r.t_measure},
            "peak_memory_bytes_per_rank": [m for m, _ in allm],
            "peak_rss_bytes_per_rank": [s for _, s in allm],
            "iteration_detail": [
                {"iter": it.iter, "tagged": it.ntagged, "pieces": it.npieces,
                 "rolled_back": it.nfailed, "imbalance": it.imbalance, "elements": it.nelem,
                 "tag_s": it.t_tag, "pieces_s": it.t_pieces, "gather_s": it.t_gather,
                 "remesh_s": it.t_remesh, "reintegrate_s": it.t_reintegrate,
                 "remesh_busy_s": it.remesh_busy, "remesh_cpu_s": it.remesh_cpu,
                 "nsplit": it.nsplit, "ncollapse": it.ncollapse, "nswap": it.nswap,
                 "nmove": it.nmove, "bytes_moved": it.bytes_moved,
                 "peak_bytes": {"tag": it.mem_tag, "pieces": it.mem_pieces,
                                "gather": it.mem_gather, "remesh": it.mem_remesh,
                                "reintegrate": it.mem_reintegrate},
                 "bytes_after": it.mem_after}
                for it in r.iters[:r.niter_recorded]],
        })
        d["transfer"] = transfer_dict(r.transfer)
        d.update(fidelity_dict(r.fidelity))
        return Report(d, describe(r.fidelity))

    def __repr__(self):
        if self._dm is None:
            return "<padapt.DistributedMesh (closed)>"
        return "<padapt.DistributedMesh %dD rank %d/%d: %d/%d owned elements, overlap %d>" % (
            self.dim, self.comm.rank, self.comm.size, self.nowned("element"),
            self.nglobal("element"), self.overlap)
