"""padapt.geometry: the CAD model a classified mesh discretizes, for
adapt(..., geometry=...): Gmsh's (Geometry.read, through Gmsh's library) or
your own kernel as Python callables (Geometry(closest, curvature, size)).
See docs/guide/geometry.md."""
import ctypes
import os

import numpy as np

from . import _lib
from ._lib import lib, check

__all__ = ["Geometry", "available"]


def available():
    """(True, "") when Geometry.read can load models (padapt was built with
    Gmsh's library and it loads), else (False, the reason)."""
    why = ctypes.c_char_p()
    ok = lib.pa_geometry_available(ctypes.byref(why))
    return bool(ok), (why.value or b"").decode()


class Geometry(object):
    """A model the remeshers project onto.

    Geometry(closest, curvature=None, size=...) wraps your own kernel:
      closest(dim, tag, x) -> y     the point of entity (dim, tag), dim 0
                                    (point), 1 (curve) or 2 (surface),
                                    closest to x; x and y are 3 coordinates
                                    (z = 0 for a 2D mesh); raise, or return
                                    None, when it cannot
      curvature(dim, tag, y) -> k   the largest absolute curvature of curve
                                    or surface (dim, tag) at its point y
                                    (optional: -hausd is then measured on
                                    the facets)
      size                          the diagonal of the model's box (> 0)
    Geometry.read(path) loads a .geo, .step/.stp, .brep or .iges/.igs file
    through Gmsh's library (one at a time per process).
    """

    def __init__(self, closest, curvature=None, size=1.0):
        if not callable(closest):
            raise TypeError("Geometry: closest must be callable")
        if curvature is not None and not callable(curvature):
            raise TypeError("Geometry: curvature must be callable or None")
        self._closest, self._curvature = closest, curvature

        def c_closest(ctx, dim, tag, x, y):
            try:
                p = closest(dim, tag, np.array(x[:3]))
                if p is None:
                    return 1
                p = np.asarray(p, dtype=float).reshape(3)
                for k in range(3):
                    y[k] = float(p[k])
                return 0
            except Exception:  # a failure the remeshers handle
                return 1

        def c_curvature(ctx, dim, tag, y, kappa):
            try:
                k = curvature(dim, tag, np.array(y[:3]))
                if k is None:
                    return 1
                kappa[0] = float(k)
                return 0
            except Exception:
                return 1

        self._ops = _lib.GeometryOps(
            _lib.GEOM_CLOSEST(c_closest),
            _lib.GEOM_CURVATURE(c_curvature) if curvature else
            _lib.GEOM_CURVATURE())
        self._h = ctypes.c_void_p()
        check(lib.pa_geometry_create(ctypes.byref(self._ops), None, float(size),
                                     ctypes.byref(self._h)))

    @classmethod
    def read(cls, path):
        """Load the model at path through Gmsh's library. Raises padapt.Error
        naming the file (unreadable, or padapt built without Gmsh's library:
        see available()), FileNotFoundError when path does not exist."""
        if not os.path.exists(path):
            raise FileNotFoundError(2, "No such file", str(path))
        g = cls.__new__(cls)
        g._ops = None
        g._h = ctypes.c_void_p()
        check(lib.pa_geometry_read(os.fsencode(path), ctypes.byref(g._h)))
        return g

    def __del__(self):
        h = getattr(self, "_h", None)
        if h:
            lib.pa_geometry_destroy(h)
            self._h = None

    def close(self):
        """Release the model now (Gmsh's model is unloaded)."""
        self.__del__()

    @property
    def size(self):
        """The diagonal of the model's bounding box."""
        return lib.pa_geometry_size(self._h)

    def closest(self, dim, tag, x):
        """The point of entity (dim, tag) closest to x (3 coordinates)."""
        p = np.ascontiguousarray(x, dtype=float).reshape(3)
        y = np.zeros(3)
        check(lib.pa_geometry_closest(self._h, int(dim), int(tag), _lib.ptr(p), _lib.ptr(y)))
        return y

    def check(self, mesh, tol=-1.0):
        """How far the vertices of a classified mesh lie from their entities:
        {"vertices", "dist_max", "dist_mean", "worst" (vertex index or -1),
        "worst_entity" ((dim, tag)), "seconds"}. With tol >= 0, raises
        padapt.Error naming the first vertex farther than tol times size, or
        on an entity the model lacks."""
        r = _lib.GeometryReport()
        check(lib.pa_geometry_check(self._h, mesh._h, float(tol), ctypes.byref(r)))
        return {"vertices": r.nvert, "dist_max": r.dist_max, "dist_mean": r.dist_mean,
                "worst": r.worst, "worst_entity": (r.worst_dim, r.worst_tag),
                "seconds": r.seconds}
