"""padapt.Mesh: a sequential simplex mesh held by the C library.

Entity arrays (points, cells, boundary, edges, references, flags) are numpy
views of the library's own storage: no copy when reading them, and writes to
the writable ones (points, references, flags) go straight to the mesh. The
connectivity views are read-only: the entity counts and connectivity of a
Mesh never change after it is built (adapt returns a new Mesh), so views stay
valid for as long as any of them, or the Mesh, is alive. The metric and the
fields are returned as copies, because setting them replaces their storage.
Building a Mesh from arrays copies each array once into the library.
"""
import ctypes
import math
import os

import numpy as np

from . import _lib
from ._lib import lib, check

__all__ = ["Mesh", "read", "FLAG_CORNER", "FLAG_RIDGE", "FLAG_REQUIRED", "FLAG_USER"]

FLAG_CORNER = 1    #: vertex: corner, never removed nor moved
FLAG_RIDGE = 2     #: edge (or vertex on a ridge): sharp feature
FLAG_REQUIRED = 4  #: entity frozen: never modified by the remesher
FLAG_USER = 8      #: free for callers

_INT32_MAX = 2 ** 31 - 1


class _WriteOpts(ctypes.Structure):
    _fields_ = [("binary", ctypes.c_int), ("version", ctypes.c_int),
                ("diagnostics", ctypes.c_int)]


lib.pa_mesh_write.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.POINTER(_WriteOpts)]


# ------------------------------------------------------------ statistics

def _num(x):
    return x if math.isfinite(x) else None


def _ratio(n, total):
    return n / total if total > 0 else 0.0


def stats_dict(s):
    """The members of pa_stats_write_json, from a pa_stats."""
    return {
        "padapt_version": _lib.lib.pa_version().decode(),
        "dim": s.dim, "vertices": s.nvert, "elements": s.nelem, "boundary": s.nbdry,
        "volume": _num(s.volume), "inverted": s.ninverted, "valid": bool(s.valid),
        "has_metric": bool(s.has_metric), "edges": s.nedge,
        "edge_min": _num(s.edge_min), "edge_max": _num(s.edge_max),
        "edge_mean": _num(s.edge_sum / s.nedge if s.nedge > 0 else 0.0),
        "edge_in_range": _ratio(s.edge_hist[_lib.STATS_EDGE_NBIN - 1], s.nedge),
        "edge_hist": list(s.edge_hist),
        "quality_worst": _num(s.qual_min),
        "quality_mean": _num(s.qual_sum / s.nelem if s.nelem > 0 else 0.0),
        "quality_best": _num(s.qual_max),
        "quality_above_0.5": _ratio(s.qual_above_05, s.nelem),
        "quality_above_0.12": _ratio(s.qual_above_012, s.nelem),
        "quality_hist": list(s.qual_hist),
    }



# ------------------------------------------------------------ input checks
# Every check raises ValueError naming the argument, before any C call.

def _array(name, a):
    try:
        return np.asarray(a)
    except Exception as exc:  # ragged lists and the like
        raise ValueError("%s: not an array (%s)" % (name, exc)) from None


def as_float(name, a, shape):
    """a as a C-contiguous float64 array of the given shape (None: any)."""
    a = _array(name, a)
    if a.dtype.kind not in "fiu":
        raise ValueError("%s: expected real numbers, got dtype %s" % (name, a.dtype))
    if shape is not None and (a.ndim != len(shape) or
                              any(s is not None and s != t for s, t in zip(shape, a.shape))):
        raise ValueError("%s: expected shape %s, got %s" % (
            name, tuple("n" if s is None else s for s in shape), a.shape))
    a = np.ascontiguousarray(a, dtype=np.float64)
    bad = ~np.isfinite(a)
    if bad.any():
        i = np.argwhere(bad)[0]
        raise ValueError("%s: value at %s is not finite (%r)" % (name, tuple(int(k) for k in i), a[tuple(i)]))
    return a


def as_index(name, a, ncol, nvert):
    """a as a C-contiguous int32 (m, ncol) array of vertex indices < nvert."""
    a = _array(name, a)
    if a.size == 0 and a.ndim <= 2:
        return np.zeros((0, ncol), np.int32)
    if a.dtype.kind not in "iu":
        raise ValueError("%s: expected an integer array, got dtype %s" % (name, a.dtype))
    if a.ndim != 2 or a.shape[1] != ncol:
        raise ValueError("%s: expected shape (n, %d), got %s" % (name, ncol, a.shape))
    lo, hi = int(a.min()), int(a.max())
    if lo < 0 or hi >= nvert:
        i = int(np.argmax((a < 0).any(axis=1) | (a >= nvert).any(axis=1)))
        raise ValueError("%s: row %d has vertex index %s outside [0, %d)" % (
            name, i, a[i].tolist(), nvert))
    return np.ascontiguousarray(a, dtype=np.int32)


def as_refs(name, a, n):
    """a as int32 (n,) references (None: zeros)."""
    if a is None:
        return None
    a = _array(name, a)
    if a.ndim == 0:
        a = np.full(n, a)
    if a.dtype.kind not in "iu":
        raise ValueError("%s: expected an integer array, got dtype %s" % (name, a.dtype))
    if a.shape != (n,):
        raise ValueError("%s: expected shape (%d,), got %s" % (name, n, a.shape))
    if n and (int(a.min()) < -_INT32_MAX - 1 or int(a.max()) > _INT32_MAX):
        raise ValueError("%s: references must fit in 32 bits" % name)
    return np.ascontiguousarray(a, dtype=np.int32)


def as_mask(name, a, n):
    """a as a bool (n,) mask (None: None)."""
    if a is None:
        return None
    a = _array(name, a)
    if a.dtype.kind not in "biu":
        raise ValueError("%s: expected a boolean mask, got dtype %s" % (name, a.dtype))
    if a.shape != (n,):
        raise ValueError("%s: expected shape (%d,), got %s" % (name, n, a.shape))
    return a.astype(bool)


def tensor_ncomp(dim):
    return 3 if dim == 2 else 6


def as_metric(name, m, dim, nvert):
    """A metric (nvert,) of sizes or (nvert, 3|6) of SPD tensors m11 m12 m22
    [m13 m23 m33], checked (finite, positive sizes, positive definite by
    Sylvester's criterion), as a C-contiguous float64 array of ncomp columns,
    and ncomp."""
    m = _array(name, m)
    if m.ndim == 2 and m.shape[1] == 1:
        m = m[:, 0]
    nc = 1 if m.ndim == 1 else (m.shape[1] if m.ndim == 2 else -1)
    if m.ndim not in (1, 2) or m.shape[0] != nvert or nc not in (1, tensor_ncomp(dim)):
        raise ValueError("%s: expected sizes (%d,) or %dD tensors (%d, %d), got shape %s"
                         % (name, nvert, dim, nvert, tensor_ncomp(dim), m.shape))
    m = as_float(name, m, None)
    if nc == 1:
        bad = m <= 0
        what = "size is not positive"
    else:
        m = m.reshape(nvert, nc)
        if dim == 2:
            a, b, c = m[:, 0], m[:, 1], m[:, 2]
            bad = (a <= 0) | (a * c - b * b <= 0)
        else:
            a, b, c, d, e, f = (m[:, k] for k in range(6))  # m11 m12 m22 m13 m23 m33
            det = a * (c * f - e * e) - b * (b * f - e * d) + d * (b * e - c * d)
            bad = (a <= 0) | (a * c - b * b <= 0) | (det <= 0)
        what = "tensor is not positive definite"
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError("%s: vertex %d: %s (%s)" % (name, i, what, m[i].tolist() if nc > 1 else m[i]))
    return m, nc


def as_field(name, values, nvert):
    """A vertex (or element, boundary) field (n,) or (n, k), checked,
    float64, and k."""
    v = _array(name, values)
    if v.ndim not in (1, 2) or v.shape[0] != nvert or (v.ndim == 2 and v.shape[1] < 1):
        raise ValueError("field %r: expected shape (%d,) or (%d, k), got %s"
                         % (name, nvert, nvert, v.shape))
    v = as_float("field %r" % name, v, None)
    return v, (1 if v.ndim == 1 else v.shape[1])


# Entities of fields (pa_entity) and the transfer modes (pa_transfer).
VERTEX, ELEMENT, BOUNDARY = 0, 1, 2
TRANSFERS = ("conservative", "bounded", "nearest")


def transfer_code(name, mode):
    """The pa_transfer code of a transfer mode name (ValueError listing the
    valid ones otherwise)."""
    code = ctypes.c_int()
    if not isinstance(mode, str) or lib.pa_transfer_parse(mode.encode(), ctypes.byref(code)):
        lib.pa_clear_error()
        raise ValueError("%s: unknown transfer mode %r (valid: %s)"
                         % (name, mode, ", ".join(TRANSFERS)))
    return code.value


def _check_name(name):
    if not isinstance(name, str) or not name or len(name.encode()) >= 64:
        raise ValueError("field names must be non-empty strings of under 64 bytes: %r" % (name,))


# ------------------------------------------------------------------ Mesh

class Mesh(object):
    """A simplex mesh: triangles (dim 2) or tetrahedra (dim 3).

    Mesh(points, cells, boundary=None, *, edges=None, point_refs=None,
         cell_refs=None, boundary_refs=None, edge_refs=None,
         required_points=None, required_cells=None, required_boundary=None,
         required_edges=None, metric=None, fields=None,
         cell_fields=None, boundary_fields=None)

    points    (n, dim) coordinates; dim = points.shape[1] (2 or 3)
    cells     (m, dim+1) vertex indices, 0-based, positively oriented
              (counter-clockwise triangles; tetrahedra with
              det(v1-v0, v2-v0, v3-v0) > 0)
    boundary  (b, dim) boundary entities: edges in 2D, triangles in 3D;
              None lists every face without a neighbour (reference 0)
    edges     (k, 2) feature edges (ridges, required edges), 3D only
    *_refs    integer references, one per entity (default 0)
    required_* boolean masks: entities the remesher must keep as they are
    metric    sizes (n,) or tensors (n, 3) in 2D / (n, 6) in 3D, ordered
              m11 m12 m22 [m13 m23 m33]
    fields    {name: (n,) or (n, k) array}: vertex fields interpolated by
              adapt() onto the new mesh
    cell_fields      {name: (m,) or (m, k) array, or (array, mode)}: element
              fields, carried by adapt() by their transfer mode
              ("conservative" by default, "bounded", "nearest")
    boundary_fields  {name: (b,) or (b, k) array}: boundary fields, each new
              boundary entity taking the values of the old one (same
              reference) nearest to it

    Arrays are checked (shape, dtype, finite values, indices in range)
    before anything reaches the library, raising ValueError; the mesh
    itself (orientation, conformity, ...) is checked by check() and by
    adapt(). Each array is copied once into the library's storage.
    """

    def __init__(self, points, cells, boundary=None, *, edges=None, point_refs=None,
                 cell_refs=None, boundary_refs=None, edge_refs=None,
                 required_points=None, required_cells=None, required_boundary=None,
                 required_edges=None, metric=None, fields=None, cell_fields=None,
                 boundary_fields=None):
        p = _array("points", points)
        if p.ndim != 2 or p.shape[1] not in (2, 3):
            raise ValueError("points: expected shape (n, 2) or (n, 3), got %s" % (p.shape,))
        dim = p.shape[1]
        c0 = np.shape(cells)
        if dim == 3 and len(c0) == 2 and c0[1] == 3:
            raise ValueError("cells: triangles with 3D points; a 2D mesh takes (n, 2) points "
                             "(points[:, :2]); surface meshes are not supported")
        p = as_float("points", p, (None, dim))
        nv = p.shape[0]
        if nv > _INT32_MAX:
            raise ValueError("points: more than 2^31-1 vertices")
        c = as_index("cells", cells, dim + 1, nv)
        b = None if boundary is None else as_index("boundary", boundary, dim, nv)
        if edges is not None and dim == 2:
            raise ValueError("edges: feature edges exist in 3D only (in 2D, boundary edges)")
        e = np.zeros((0, 2), np.int32) if edges is None else as_index("edges", edges, 2, nv)
        nb = 0 if b is None else b.shape[0]
        if boundary is None and (boundary_refs is not None or required_boundary is not None):
            raise ValueError("boundary_refs/required_boundary given without boundary")
        refs = [as_refs("point_refs", point_refs, nv), as_refs("cell_refs", cell_refs, c.shape[0]),
                as_refs("boundary_refs", boundary_refs, nb), as_refs("edge_refs", edge_refs, e.shape[0])]
        masks = [as_mask("required_points", required_points, nv),
                 as_mask("required_cells", required_cells, c.shape[0]),
                 as_mask("required_boundary", required_boundary, nb),
                 as_mask("required_edges", required_edges, e.shape[0])]
        met = None if metric is None else as_metric("metric", metric, dim, nv)
        flds = []
        for name, val in (fields or {}).items():
            if not isinstance(name, str) or not name or len(name.encode()) >= 64:
                raise ValueError("field names must be non-empty strings of under 64 bytes: %r" % (name,))
            flds.append((name,) + as_field(name, val, nv))
        if len(flds) > 16:
            raise ValueError("fields: at most 16 vertex fields")

        h = ctypes.c_void_p()
        check(lib.pa_mesh_create(dim, ctypes.byref(h)))
        self._h = h
        self._owner = None
        check(lib.pa_mesh_resize(h, nv, c.shape[0], nb, e.shape[0]))
        self.points[...] = p
        self._raw(lib.pa_mesh_elems, (c.shape[0], dim + 1), np.int32)[...] = c
        if b is not None:
            self._raw(lib.pa_mesh_bdrys, (nb, dim), np.int32)[...] = b
        if e.shape[0]:
            self._raw(lib.pa_mesh_edges, e.shape, np.int32)[...] = e
        for r, view in zip(refs, (self.point_refs, self.cell_refs, self.boundary_refs, self.edge_refs)):
            if r is not None:
                view[...] = r
        for m, view in zip(masks, (self.point_flags, self.cell_flags, self.boundary_flags, self.edge_flags)):
            if m is not None:
                view[m] |= FLAG_REQUIRED
        lib.pa_mesh_invalidate(h)
        if b is None:
            check(lib.pa_mesh_build_boundary(h, 0, None))
        if met is not None:
            check(lib.pa_mesh_set_metric(h, met[1], _lib.ptr(met[0])))
        for name, val, nc in flds:
            check(lib.pa_mesh_add_field(h, name.encode(), nc, _lib.ptr(val)))
        for name, val in (cell_fields or {}).items():
            mode = None
            if isinstance(val, tuple):
                val, mode = val
            self.add_cell_field(name, val, transfer=mode)
        for name, val in (boundary_fields or {}).items():
            self.add_boundary_field(name, val)

    @classmethod
    def _wrap(cls, handle, owner=None):
        """A Mesh over a C pa_mesh: owned (destroyed with the Mesh) when
        owner is None, else borrowed from owner (kept alive)."""
        m = cls.__new__(cls)
        m._h = handle if isinstance(handle, ctypes.c_void_p) else ctypes.c_void_p(handle)
        m._owner = owner
        return m

    def __del__(self):
        if self.__dict__.get("_owner") is None:
            h = self.__dict__.get("_h")
            if h:
                lib.pa_mesh_destroy(h)
                self._h = None

    # -------------------------------------------------------------- sizes
    @property
    def dim(self):
        """2 (triangles) or 3 (tetrahedra)."""
        return lib.pa_mesh_dim(self._h)

    @property
    def nvert(self):
        """Number of vertices."""
        return lib.pa_mesh_nvert(self._h)

    @property
    def nelem(self):
        """Number of elements (cells)."""
        return lib.pa_mesh_nelem(self._h)

    @property
    def nbdry(self):
        """Number of boundary entities (edges in 2D, triangles in 3D)."""
        return lib.pa_mesh_nbdry(self._h)

    @property
    def nedge(self):
        """Number of feature edges (3D)."""
        return lib.pa_mesh_nedge(self._h)

    def __repr__(self):
        return "<padapt.Mesh %dD: %d vertices, %d elements, %d boundary, %d edges>" % (
            self.dim, self.nvert, self.nelem, self.nbdry, self.nedge)

    # ------------------------------------------------------------- arrays
    def _raw(self, fn, shape, dtype, writable=True):
        return _lib.view(self, fn(self._h), shape, dtype, writable)

    @property
    def points(self):
        """(nvert, dim) float64 coordinates: a writable view."""
        return self._raw(lib.pa_mesh_coords, (self.nvert, self.dim), np.float64)

    @property
    def cells(self):
        """(nelem, dim+1) int32 vertex indices: a read-only view."""
        return self._raw(lib.pa_mesh_elems, (self.nelem, self.dim + 1), np.int32, False)

    @property
    def boundary(self):
        """(nbdry, dim) int32 vertex indices of the boundary entities: a read-only view."""
        return self._raw(lib.pa_mesh_bdrys, (self.nbdry, self.dim), np.int32, False)

    @property
    def edges(self):
        """(nedge, 2) int32 vertex indices of the feature edges: a read-only view."""
        return self._raw(lib.pa_mesh_edges, (self.nedge, 2), np.int32, False)

    point_refs = property(lambda s: s._raw(lib.pa_mesh_vert_refs, (s.nvert,), np.int32),
                          doc="(nvert,) int32 vertex references: a writable view.")
    cell_refs = property(lambda s: s._raw(lib.pa_mesh_elem_refs, (s.nelem,), np.int32),
                         doc="(nelem,) int32 element references: a writable view.")
    boundary_refs = property(lambda s: s._raw(lib.pa_mesh_bdry_refs, (s.nbdry,), np.int32),
                             doc="(nbdry,) int32 boundary references: a writable view.")
    edge_refs = property(lambda s: s._raw(lib.pa_mesh_edge_refs, (s.nedge,), np.int32),
                         doc="(nedge,) int32 feature edge references: a writable view.")
    point_flags = property(lambda s: s._raw(lib.pa_mesh_vert_flags, (s.nvert,), np.uint8),
                           doc="(nvert,) uint8 FLAG_* bits of the vertices: a writable view.")
    cell_flags = property(lambda s: s._raw(lib.pa_mesh_elem_flags, (s.nelem,), np.uint8),
                          doc="(nelem,) uint8 FLAG_* bits of the elements: a writable view.")
    boundary_flags = property(lambda s: s._raw(lib.pa_mesh_bdry_flags, (s.nbdry,), np.uint8),
                              doc="(nbdry,) uint8 FLAG_* bits of the boundary entities: a writable view.")
    edge_flags = property(lambda s: s._raw(lib.pa_mesh_edge_flags, (s.nedge,), np.uint8),
                          doc="(nedge,) uint8 FLAG_* bits of the feature edges: a writable view.")

    # ---------------------------------------------------- metric and fields
    @property
    def metric(self):
        """The metric as a copy: (nvert,) sizes or (nvert, 3|6) tensors, or
        None. Assign an array to set it (checked), None to remove it."""
        nc = lib.pa_mesh_metric_ncomp(self._h)
        if nc == 0:
            return None
        a = self._raw(lib.pa_mesh_metric, (self.nvert, nc), np.float64).copy()
        return a[:, 0] if nc == 1 else a

    @metric.setter
    def metric(self, values):
        if values is None:
            check(lib.pa_mesh_set_metric(self._h, 0, None))
            return
        m, nc = as_metric("metric", values, self.dim, self.nvert)
        check(lib.pa_mesh_set_metric(self._h, nc, _lib.ptr(m)))

    @property
    def fields(self):
        """{name: array} copies of the vertex fields ((nvert,) for one component)."""
        out = {}
        for k in range(lib.pa_mesh_nfield(self._h)):
            name, nc, val = ctypes.c_char_p(), ctypes.c_int(), _lib.c_dbl_p()
            check(lib.pa_mesh_field(self._h, k, ctypes.byref(name), ctypes.byref(nc), ctypes.byref(val)))
            a = _lib.view(self, ctypes.cast(val, ctypes.c_void_p).value, (self.nvert, nc.value), np.float64).copy()
            out[name.value.decode()] = a[:, 0] if nc.value == 1 else a
        return out

    def add_field(self, name, values):
        """Attach a vertex field (nvert,) or (nvert, k), copied; interpolated
        by adapt(). Replaces a field of the same name."""
        if not isinstance(name, str) or not name or len(name.encode()) >= 64:
            raise ValueError("field names must be non-empty strings of under 64 bytes: %r" % (name,))
        v, nc = as_field(name, values, self.nvert)
        if name in self.fields:
            self.remove_field(name)
        check(lib.pa_mesh_add_field(self._h, name.encode(), nc, _lib.ptr(v)))

    def remove_field(self, name):
        """Remove the vertex field called name (KeyError if there is none)."""
        names = list(self.fields)
        if name not in names:
            raise KeyError(name)
        check(lib.pa_mesh_remove_field(self._h, names.index(name)))

    def _fields_at(self, at, n):
        out = {}
        for k in range(lib.pa_mesh_nfield_at(self._h, at)):
            name, nc, val = ctypes.c_char_p(), ctypes.c_int(), _lib.c_dbl_p()
            check(lib.pa_mesh_field_at(self._h, at, k, ctypes.byref(name), ctypes.byref(nc),
                                       ctypes.byref(val)))
            a = _lib.view(self, ctypes.cast(val, ctypes.c_void_p).value, (n, nc.value),
                          np.float64).copy()
            out[name.value.decode()] = a[:, 0] if nc.value == 1 else a
        return out

    def _add_at(self, at, n, name, values, transfer=None):
        _check_name(name)
        v, nc = as_field(name, values, n)
        code = None if transfer is None else transfer_code(name, transfer)
        names = list(self._fields_at(at, n))
        if name in names:
            check(lib.pa_mesh_remove_field_at(self._h, at, names.index(name)))
        check(lib.pa_mesh_add_field_at(self._h, at, name.encode(), nc, _lib.ptr(v)))
        if code is not None:
            k = lib.pa_mesh_nfield_at(self._h, at) - 1
            st = lib.pa_mesh_set_field_transfer(self._h, at, k, code)
            if st:
                msg = lib.pa_last_error().decode(errors="replace")
                lib.pa_clear_error()
                check(lib.pa_mesh_remove_field_at(self._h, at, k))
                raise ValueError(msg)

    @property
    def cell_fields(self):
        """{name: array} copies of the element fields ((nelem,) for one
        component)."""
        return self._fields_at(ELEMENT, self.nelem)

    @property
    def boundary_fields(self):
        """{name: array} copies of the boundary fields ((nbdry,) for one
        component)."""
        return self._fields_at(BOUNDARY, self.nbdry)

    @property
    def transfers(self):
        """{name: mode} of the element fields: how adapt() carries each
        ("conservative", "bounded" or "nearest"; see docs/guide/fields.md)."""
        return {n: lib.pa_transfer_name(lib.pa_mesh_field_transfer(self._h, ELEMENT, k)).decode()
                for k, n in enumerate(self.cell_fields)}

    def add_cell_field(self, name, values, transfer=None):
        """Attach an element field (nelem,) or (nelem, k), copied, carried by
        adapt() by its transfer mode: "conservative" (the default: the
        integral kept), "bounded" (conservative and within the values it
        overlaps) or "nearest" (integer data keeps its values). Replaces a
        field of the same name."""
        self._add_at(ELEMENT, self.nelem, name, values, transfer)

    def add_boundary_field(self, name, values):
        """Attach a boundary field (nbdry,) or (nbdry, k), copied; adapt()
        gives each new boundary entity the values of the old one of the same
        reference nearest to it. Replaces a field of the same name."""
        self._add_at(BOUNDARY, self.nbdry, name, values)

    def remove_cell_field(self, name):
        """Remove the element field called name (KeyError if none)."""
        names = list(self.cell_fields)
        if name not in names:
            raise KeyError(name)
        check(lib.pa_mesh_remove_field_at(self._h, ELEMENT, names.index(name)))

    def remove_boundary_field(self, name):
        """Remove the boundary field called name (KeyError if none)."""
        names = list(self.boundary_fields)
        if name not in names:
            raise KeyError(name)
        check(lib.pa_mesh_remove_field_at(self._h, BOUNDARY, names.index(name)))

    @property
    def names(self):
        """The physical names (Gmsh $PhysicalNames) as a list of (dim, tag,
        name), sorted by dim then tag: the entities of dimension dim (0-3)
        and reference tag are called name. Assign such a list to replace
        them all (names are non-empty, without double quote or line break)."""
        out = []
        for k in range(lib.pa_mesh_nnames(self._h)):
            d, t, n = ctypes.c_int(), ctypes.c_int32(), ctypes.c_char_p()
            check(lib.pa_mesh_name(self._h, k, ctypes.byref(d), ctypes.byref(t), ctypes.byref(n)))
            out.append((d.value, t.value, n.value.decode()))
        return out

    @names.setter
    def names(self, items):
        items = [(int(d), int(t), str(n)) for d, t, n in items]
        for d, t, _ in self.names:
            check(lib.pa_mesh_add_name(self._h, d, t, None))
        for d, t, n in items:
            check(lib.pa_mesh_add_name(self._h, d, t, n.encode()))

    # ------------------------------------------------------------- checks
    def check(self):
        """Check the mesh (indices, orientation, conformity, boundary listed,
        no unused vertex, finite coordinates, valid metric, manifold
        vertices); raise padapt.Error naming the first fault."""
        lib.pa_mesh_invalidate(self._h)
        check(lib.pa_mesh_check(self._h))

    def volume(self):
        """Sum of the signed element volumes (areas in 2D)."""
        return lib.pa_mesh_volume(self._h)

    def quality(self):
        """(nelem,) element qualities in Mmg's normalisation (1 regular,
        0 flat), in the metric (identity without one)."""
        q = lib.pa_mesh_elem_quality
        return np.fromiter((q(self._h, e) for e in range(self.nelem)), np.float64, self.nelem)

    def stats(self):
        """Statistics as `padapt stats -json` writes them (a dict): counts,
        volume, validity, edge lengths and qualities in the metric."""
        s = _lib.Stats()
        lib.pa_mesh_invalidate(self._h)
        check(lib.pa_mesh_stats(self._h, ctypes.byref(s)))
        return stats_dict(s)

    def memory_used(self):
        """Bytes used by the mesh in the library."""
        return lib.pa_mesh_memory_used(self._h)

    def copy(self):
        """A deep copy (metric and every field included)."""
        h = ctypes.c_void_p()
        check(lib.pa_mesh_copy(self._h, ctypes.byref(h)))
        return Mesh._wrap(h)

    # ----------------------------------------------------------------- I/O
    def write(self, path, binary=False, version=0):
        """Write the mesh, format by extension: .mesh/.meshb (Medit; version
        1-4 for .meshb), .msh (Gmsh 4.1, binary=True for binary; element and
        boundary fields as $ElementData), .vtu (with the metric and vertex
        fields as point data, element and boundary fields as cell data). All or nothing: written to a
        temporary file then renamed."""
        o = _WriteOpts(1 if binary else 0, int(version))
        check(lib.pa_mesh_write(self._h, os.fsencode(path), ctypes.byref(o)))

    @classmethod
    def generate_box(cls, dim, n):
        """The unit square split in n x n x 2 triangles (dim 2) or the unit
        cube in n^3 x 6 tetrahedra (dim 3); boundary references 1-4 (2D) or
        1-6 (3D) by side (x=0, x=1, y=0, y=1, z=0, z=1)."""
        if dim not in (2, 3) or int(n) < 1:
            raise ValueError("generate_box: dim must be 2 or 3 and n >= 1")
        h = ctypes.c_void_p()
        check(lib.pa_mesh_generate_box(int(dim), int(n), ctypes.byref(h)))
        return cls._wrap(h)

    # -------------------------------------------------------------- meshio
    def to_meshio(self):
        """A meshio.Mesh: cells "triangle"/"tetra", boundary cells "line"
        (2D) or "triangle" (3D), feature edges "line" (3D); references as
        cell data "medit:ref" and point data "medit:ref"; the metric as point
        data "metric" and each field under its name; the physical names as
        field_data {name: [tag, dim]}. Arrays are copies."""
        import meshio
        dim = self.dim
        kind = {2: ("triangle", "line"), 3: ("tetra", "triangle")}[dim]
        blocks = [(kind[0], self.cells.copy(), self.cell_refs.copy())]
        if self.nbdry:
            blocks.append((kind[1], self.boundary.copy(), self.boundary_refs.copy()))
        if self.nedge:
            blocks.append(("line", self.edges.copy(), self.edge_refs.copy()))
        point_data = {"medit:ref": self.point_refs.copy()}
        if self.metric is not None:
            point_data["metric"] = self.metric
        point_data.update(self.fields)
        cell_data = {"medit:ref": [r for _, _, r in blocks]}
        # element and boundary fields: NaN on the blocks they are not on
        per_block = [self.cell_fields, self.boundary_fields if self.nbdry else {}, {}]
        for name in dict.fromkeys(list(per_block[0]) + list(per_block[1])):
            shape = next(f[name].shape[1:] for f in per_block if name in f)
            cell_data[name] = [pb[name] if name in pb and pb[name].shape[1:] == shape
                               else np.full((len(c),) + shape, np.nan)
                               for pb, (_, c, _) in zip(per_block, blocks)]
        return meshio.Mesh(self.points.copy(), [(t, c) for t, c, _ in blocks],
                           point_data=point_data, cell_data=cell_data,
                           field_data={n: np.array([t, d]) for d, t, n in self.names})

    @classmethod
    def from_meshio(cls, m, dim=None):
        """A Mesh from a meshio.Mesh. dim: 3 if there are tetrahedra, else 2
        (points must then lie in the plane z = 0 if they have 3 coordinates).
        Elements: "tetra" (3D) or "triangle" (2D); boundary: "triangle" (3D)
        or "line" (2D), completed with reference 0 where faces without a
        neighbour are not listed; feature edges: "line" (3D).
        References from cell data "medit:ref", else "gmsh:physical"; vertex
        references from point data "medit:ref". Point data "metric" becomes
        the metric, other real point data with one value (or row) per vertex
        become fields. Real cell data other than the references becomes an
        element field where it has a finite value on every element, and a
        boundary field where it has one on every listed boundary entity (NaN
        marks the blocks a field is not on, as to_meshio writes them).
        field_data entries [tag, dim] become the physical names. Other cell
        types are ignored."""
        types = [b.type for b in m.cells]
        if dim is None:
            dim = 3 if "tetra" in types else 2
        if dim not in (2, 3):
            raise ValueError("from_meshio: dim must be 2 or 3")
        pts = np.asarray(m.points)
        if pts.ndim != 2 or pts.shape[1] not in (2, 3):
            raise ValueError("from_meshio: points of shape %s" % (pts.shape,))
        if dim == 2 and pts.shape[1] == 3:
            if np.any(pts[:, 2] != 0):
                raise ValueError("from_meshio: a 2D mesh needs points in the plane z = 0")
            pts = pts[:, :2]
        if dim == 3 and pts.shape[1] != 3:
            raise ValueError("from_meshio: a 3D mesh needs 3 coordinates")

        def refs_of(i):
            for key in ("medit:ref", "gmsh:physical"):
                if key in m.cell_data:
                    return np.asarray(m.cell_data[key][i])
            return np.zeros(len(m.cells[i].data), np.int32)

        def gather(t):
            idx = [i for i, b in enumerate(m.cells) if b.type == t]
            if not idx:
                return None, None
            return (np.concatenate([np.asarray(m.cells[i].data) for i in idx]),
                    np.concatenate([refs_of(i) for i in idx]).astype(np.int64))

        def gather_data(t, key):
            """Cell data key on the blocks of type t, end to end; None if
            it is not real and finite on all of them."""
            idx = [i for i, b in enumerate(m.cells) if b.type == t]
            parts = [np.asarray(m.cell_data[key][i]) for i in idx]
            if not parts or any(p.dtype.kind not in "fiu" or p.ndim not in (1, 2)
                                for p in parts) or len({p.shape[1:] for p in parts}) != 1:
                return None
            v = np.concatenate(parts).astype(np.float64)
            return v if np.all(np.isfinite(v)) else None

        ctype, btype = ("tetra", "triangle") if dim == 3 else ("triangle", "line")
        cells, crefs = gather(ctype)
        if cells is None:
            raise ValueError("from_meshio: no %s cells in the mesh" % ctype)
        bdry, brefs = gather(btype)
        edges, erefs = gather("line") if dim == 3 else (None, None)
        vref = m.point_data.get("medit:ref")
        metric, fields = None, {}
        for k, v in m.point_data.items():
            v = np.asarray(v)
            if k == "metric":
                metric = v
            elif k not in ("medit:ref", "gmsh:dim_tags") and v.dtype.kind in "fiu" \
                    and v.ndim in (1, 2) and v.shape[0] == len(pts):
                fields[k] = v
        cfields, bfields = {}, {}
        for k in m.cell_data:
            if k in ("medit:ref", "gmsh:physical", "gmsh:geometrical", "cell_tags"):
                continue
            v = gather_data(ctype, k)
            if v is not None:
                cfields[k] = v
            v = gather_data(btype, k) if bdry is not None else None
            if v is not None:
                bfields[k] = v
        mesh = cls(pts, cells, bdry, edges=edges,
                   point_refs=None if vref is None else np.asarray(vref).astype(np.int64),
                   cell_refs=crefs, boundary_refs=brefs, edge_refs=erefs,
                   metric=metric, fields=fields, cell_fields=cfields,
                   boundary_fields=bfields)
        if bdry is not None:  # complete a partial list (physical groups on some sides)
            check(lib.pa_mesh_build_boundary(mesh._h, 0, None))
        mesh.names = [(int(v[1]), int(v[0]), k) for k, v in (m.field_data or {}).items()
                      if np.asarray(v).shape == (2,)]
        return mesh


def read(path):
    """Read a mesh, format by extension: .mesh/.meshb (Medit), .msh (Gmsh 4.1
    ASCII or binary, 2.2 ASCII). The boundary entities the file does not
    list are added (reference 0), as the command line does. Raises
    padapt.Error naming the file and line of a fault, FileNotFoundError if
    path does not exist."""
    if not os.path.exists(path):
        raise FileNotFoundError(2, "No such file", str(path))
    h = ctypes.c_void_p()
    check(lib.pa_mesh_read(os.fsencode(path), ctypes.byref(h)))
    mesh = Mesh._wrap(h)
    check(lib.pa_mesh_build_boundary(h, 0, None))
    return mesh
