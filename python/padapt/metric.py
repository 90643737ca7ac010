"""padapt.metric: the metric toolbox of the C library on a sequential Mesh.

Metrics are numpy arrays, one row per vertex: sizes (nvert,) or symmetric
positive definite tensors (nvert, 3) in 2D / (nvert, 6) in 3D, ordered
m11 m12 m22 [m13 m23 m33] (Medit's order). The functions return new arrays
and leave the mesh as it was (its own metric included).
"""
import contextlib
import ctypes
import math

import numpy as np

from . import _lib
from ._lib import lib, check
from .mesh import Mesh, as_float, as_metric, tensor_ncomp

__all__ = ["hessian", "recover", "levelset", "signed_distance", "analytic",
           "analytic_names", "intersect", "grade", "clamp", "complexity",
           "scale_complexity"]

_RECOVERY = {"lsq": 0, "l2": 1}
_RECOVERY_NAME = {v: k for k, v in _RECOVERY.items()}
_HESS = _lib.HESSIAN_DEFAULTS


def _mesh(mesh):
    if not isinstance(mesh, Mesh):
        raise TypeError("expected a padapt.Mesh, got %s" % type(mesh).__name__)
    return mesh


def _scalar(name, u, mesh):
    return as_float(name, u, (mesh.nvert,))


def _opt(name, x, positive=False):
    if x is None:
        return None
    try:
        x = float(x)
    except (TypeError, ValueError):
        raise ValueError("%s: expected a number, got %r" % (name, x)) from None
    if not math.isfinite(x) or (positive and x <= 0):
        raise ValueError("%s: expected a %snumber, got %r" % (name, "positive " if positive else "finite ", x))
    return x


def _out(mesh, nc):
    return np.empty((mesh.nvert, nc)) if nc > 1 else np.empty(mesh.nvert)


@contextlib.contextmanager
def _with_metric(mesh, m, nc):
    """Give mesh the metric m for the duration of the block, then restore."""
    old = mesh.metric
    check(lib.pa_mesh_set_metric(mesh._h, nc, _lib.ptr(m)))
    try:
        yield
    finally:
        if old is None:
            lib.pa_mesh_set_metric(mesh._h, 0, None)
        else:
            o, onc = as_metric("metric", old, mesh.dim, mesh.nvert)
            lib.pa_mesh_set_metric(mesh._h, onc, _lib.ptr(o))


def recover(mesh, u, method="lsq"):
    """Gradient (nvert, dim) and Hessian (nvert, 3|6: xx xy yy [xz yz zz])
    of the scalar vertex field u. method "lsq": least-squares quadratic fit
    over each vertex's neighbours (exact for quadratics); "l2": double L2
    projection (exact for linear fields)."""
    _mesh(mesh)
    u = _scalar("u", u, mesh)
    if method not in _RECOVERY:
        raise ValueError("method: 'lsq' or 'l2', got %r" % (method,))
    g = np.empty((mesh.nvert, mesh.dim))
    h = np.empty((mesh.nvert, tensor_ncomp(mesh.dim)))
    check(lib.pa_mesh_recover(mesh._h, _lib.ptr(u), 1, _RECOVERY[method], _lib.ptr(g), _lib.ptr(h)))
    return g, h


def _hessian_opts(who, target, err, p, hmin, hmax, hgrad, recovery):
    """pa_metric_hessian_opts from the keyword arguments, checked."""
    if (target is None) == (err is None):
        raise ValueError("%s: give exactly one of target= and err=" % who)
    o = _lib.HessianOpts()
    lib.pa_metric_hessian_opts_default(ctypes.byref(o))
    o.p = _opt("p", p)
    o.target = _opt("target", target, True) or 0.0
    o.err = _opt("err", err, True) or 0.0
    o.hmin = _opt("hmin", hmin, True) or 0.0
    o.hmax = _opt("hmax", hmax, True) or 0.0
    o.hgrad = -1.0 if hgrad is None else _opt("hgrad", hgrad)
    if recovery not in _RECOVERY:
        raise ValueError("recovery: 'lsq' or 'l2', got %r" % (recovery,))
    o.recovery = _RECOVERY[recovery]
    return o


def hessian(mesh, u, *, target=None, err=None, p=_HESS.p, hmin=None, hmax=None,
            hgrad=_HESS.hgrad, recovery=_RECOVERY_NAME[_HESS.recovery]):
    """The Lp-optimal metric of the scalar vertex field u (Loseille and
    Alauzet's multiscale metric M = D det|H|^(-1/(2p+d)) |H|), scaled to the
    complexity target (about 2.3 target triangles, 8.5 target tetrahedra)
    or to the estimated Lp interpolation error err (give one), clamped to
    [hmin, hmax] and graded by hgrad (None or <= 1: no gradation). p <= 0:
    L-infinity. Returns tensors (nvert, 3|6)."""
    _mesh(mesh)
    u = _scalar("u", u, mesh)
    o = _hessian_opts("hessian", target, err, p, hmin, hmax, hgrad, recovery)
    met = _out(mesh, tensor_ncomp(mesh.dim))
    check(lib.pa_metric_from_hessian(mesh._h, _lib.ptr(u), 1, ctypes.byref(o), _lib.ptr(met)))
    return met


def signed_distance(mesh, spec):
    """Signed distance (negative inside) at every vertex to an analytic
    surface: "sphere:R[:cx,cy,cz]", "ellipsoid:a,b,c[:cx,cy,cz]",
    "box:lx,ly,lz[:cx,cy,cz]", "plane:nx,ny,nz,d" (2D: "sphere:R[:cx,cy]"
    is a circle, "ellipse:a,b[:cx,cy]", "box:lx,ly[:cx,cy]",
    "plane:nx,ny,d"). Returns (nvert,)."""
    _mesh(mesh)
    phi = np.empty(mesh.nvert)
    check(lib.pa_levelset_analytic(mesh._h, str(spec).encode(), _lib.ptr(phi)))
    return phi


def levelset(mesh, phi, *, eps, hmin, hmax, band=None,
             hgrad=_lib.LEVELSET_DEFAULTS.hgrad):
    """The metric capturing the zero set of the level set phi (nvert,) to
    within the distance eps: size hmin across the zero set growing to hmax
    at the edge of the band (half-width band, default 5 hmax), the chord
    bound sqrt(8 eps / |curvature|) along it, hmax outside; graded by hgrad
    (None or <= 1: none). Returns tensors (nvert, 3|6)."""
    _mesh(mesh)
    phi = _scalar("phi", phi, mesh)
    o = _lib.LevelsetOpts()
    lib.pa_metric_levelset_opts_default(ctypes.byref(o))
    o.eps = _opt("eps", eps, True)
    o.hmin = _opt("hmin", hmin, True)
    o.hmax = _opt("hmax", hmax, True)
    if band is not None:
        o.band = _opt("band", band, True)
    o.hgrad = -1.0 if hgrad is None else _opt("hgrad", hgrad)
    met = _out(mesh, tensor_ncomp(mesh.dim))
    check(lib.pa_metric_from_levelset(mesh._h, _lib.ptr(phi), ctypes.byref(o), _lib.ptr(met)))
    return met


def analytic_names():
    """Names of the built-in analytic metric fields."""
    lib.pa_metric_analytic_names.restype = ctypes.POINTER(ctypes.c_char_p)
    names, out, k = lib.pa_metric_analytic_names(), [], 0
    while names[k]:
        out.append(names[k].decode())
        k += 1
    return out


def analytic(mesh, spec):
    """A built-in analytic metric at the vertices: "NAME" or "NAME:h" with
    NAME one of analytic_names() ("uniform", "layer", "shell", "iso-shell",
    "ugawg-linear", ...; see padapt.h). Returns sizes or tensors."""
    _mesh(mesh)
    old = mesh.metric
    check(lib.pa_metric_analytic(mesh._h, str(spec).encode()))
    try:
        return mesh.metric
    finally:
        mesh.metric = old


def intersect(a, b, *, dim=None):
    """Intersection of two metrics of the same shape (the largest metric
    contained in both, by simultaneous reduction): sizes (n,) give the
    smaller size; tensors (n, 3) are 2D, (n, 6) 3D. dim is needed only for
    sizes (default 3; it does not change the result)."""
    a = as_float("a", a, None)
    b = as_float("b", b, None)
    if a.shape != b.shape or a.ndim not in (1, 2):
        raise ValueError("intersect: metrics of shapes %s and %s" % (a.shape, b.shape))
    nc = 1 if a.ndim == 1 else a.shape[1]
    if dim is None:
        dim = {1: 3, 3: 2, 6: 3}.get(nc, 0)
    if dim not in (2, 3):
        raise ValueError("intersect: tensors have 3 (2D) or 6 (3D) components, got %d" % nc)
    a, _ = as_metric("a", a, dim, a.shape[0])
    b, _ = as_metric("b", b, dim, b.shape[0])
    out = np.empty_like(a)
    check(lib.pa_metric_intersect_all(dim, nc, a.shape[0], _lib.ptr(a), _lib.ptr(b), _lib.ptr(out)))
    return out


def grade(mesh, metric, hgrad=_lib.REMESH_DEFAULTS.hgrad,
          hgradreq=_lib.REMESH_DEFAULTS.hgradreq):
    """The metric graded on mesh: sizes grow by at most hgrad per unit
    length (hgradreq from required vertices, which keep their metric; <= 1:
    no bound)."""
    _mesh(mesh)
    m, nc = as_metric("metric", metric, mesh.dim, mesh.nvert)
    with _with_metric(mesh, m, nc):
        check(lib.pa_mesh_metric_grade(mesh._h, float(hgrad), float(hgradreq)))
        return mesh.metric


def clamp(mesh, metric, hmin=None, hmax=None):
    """The metric with every size (eigenvalue) within [hmin, hmax]."""
    _mesh(mesh)
    m, nc = as_metric("metric", metric, mesh.dim, mesh.nvert)
    lo = _opt("hmin", hmin, True) or 0.0
    hi = _opt("hmax", hmax, True) or 0.0
    with _with_metric(mesh, m, nc):
        check(lib.pa_mesh_metric_clamp(mesh._h, lo, hi))
        return mesh.metric


def complexity(mesh, metric):
    """Complexity of the metric on mesh, the integral of sqrt(det M): it
    asks for about 2.3 C triangles (2D) or 8.5 C tetrahedra (3D)."""
    _mesh(mesh)
    m, nc = as_metric("metric", metric, mesh.dim, mesh.nvert)
    c = ctypes.c_double()
    check(lib.pa_metric_complexity(mesh._h, nc, _lib.ptr(m), ctypes.byref(c)))
    return c.value


def scale_complexity(mesh, metric, target):
    """The metric scaled so that its complexity becomes target."""
    _mesh(mesh)
    m, nc = as_metric("metric", metric, mesh.dim, mesh.nvert)
    m = m.copy()
    check(lib.pa_metric_scale_complexity(mesh._h, nc, _lib.ptr(m), _opt("target", target, True)))
    return m[:, 0] if nc == 1 and m.ndim == 2 else m
