"""padapt.levelset: the level-set cut (Mmg's -ls) of a sequential Mesh.

    new, report = padapt.levelset.cut(mesh, phi)               # the cut alone
    new, fields, report = padapt.adapt(mesh, hsiz=0.02, levelset=phi)  # cut, then adapt

The zero set of phi - value (phi: one value per vertex, P1) is cut into the
mesh: elements where phi < value get reference 3, the others 2, the faces
between them become boundary entities of reference 10 (Mmg's defaults);
adapt() then keeps that interface as a boundary. See
docs/guide/levelset.md.
"""
import ctypes
import math

from . import _lib
from ._lib import lib, check, c_gid
from .mesh import Mesh, as_float

__all__ = ["cut", "REF_IN", "REF_OUT", "REF_IFACE"]

REF_IN, REF_OUT, REF_IFACE = 3, 2, 10


class Material(ctypes.Structure):
    _fields_ = [("ref", ctypes.c_int32), ("split", ctypes.c_int),
                ("ref_in", ctypes.c_int32), ("ref_out", ctypes.c_int32)]


class CutOpts(ctypes.Structure):
    _fields_ = [("value", ctypes.c_double), ("ref_in", ctypes.c_int32),
                ("ref_out", ctypes.c_int32), ("ref_iface", ctypes.c_int32),
                ("mat", ctypes.POINTER(Material)), ("nmat", ctypes.c_int),
                ("rmc", ctypes.c_double), ("snap", ctypes.c_double)]


class CutReport(ctypes.Structure):
    _fields_ = [("phi_min", ctypes.c_double), ("phi_max", ctypes.c_double),
                ("nsnapped", c_gid), ("nremoved_out", c_gid), ("nremoved_in", c_gid),
                ("ncut", c_gid), ("nelem_cut", c_gid), ("niface", c_gid),
                ("ndropped", c_gid), ("nbdry_iface", c_gid),
                ("vol_in", ctypes.c_double), ("vol_out", ctypes.c_double)]


lib.pa_levelset_opts_default.restype = None
lib.pa_levelset_opts_default.argtypes = [ctypes.POINTER(CutOpts)]
lib.pa_mesh_levelset_cut.restype = _lib.c_status
lib.pa_mesh_levelset_cut.argtypes = [ctypes.c_void_p, _lib.c_dbl_p,
                                     ctypes.POINTER(CutOpts), ctypes.POINTER(CutReport)]

_KEYS = ("value", "ref_in", "ref_out", "ref_iface", "materials", "rmc", "snap")


def _int32(name, x):
    if isinstance(x, bool) or not float(x).is_integer() or abs(int(x)) > 2 ** 31 - 1:
        raise ValueError("%s: expected a reference (an integer), got %r" % (name, x))
    return int(x)


def options(opts=None, **kw):
    """The C options of the cut from keyword arguments (None keeps a
    default): value (the iso-value), ref_in, ref_out, ref_iface, materials
    (Mmg's LSReferences: a list of (ref, ref_in, ref_out) for the
    materials split, (ref, None) for those kept whole), rmc (a share of
    the volume: smaller components change side; True: Mmg's 1e-5), snap.
    Returns (opts, keep): keep holds the materials array alive."""
    for k in kw:
        if k not in _KEYS:
            raise TypeError("unknown level-set option %r (known: %s)" % (k, ", ".join(_KEYS)))
    if opts is None:
        opts = CutOpts()
        lib.pa_levelset_opts_default(ctypes.byref(opts))
    keep = None
    for k, v in kw.items():
        if v is None:
            continue
        if k in ("ref_in", "ref_out", "ref_iface"):
            setattr(opts, k, _int32(k, v))
        elif k == "materials":
            mats = list(v)
            keep = (Material * max(1, len(mats)))()
            for i, m in enumerate(mats):
                m = tuple(m)
                if len(m) == 2 and m[1] is None:
                    keep[i] = Material(_int32("materials", m[0]), 0, 0, 0)
                elif len(m) == 3:
                    keep[i] = Material(_int32("materials", m[0]), 1,
                                       _int32("materials", m[1]), _int32("materials", m[2]))
                else:
                    raise ValueError("materials: expected (ref, ref_in, ref_out) or "
                                     "(ref, None), got %r" % (m,))
            opts.mat = ctypes.cast(keep, ctypes.POINTER(Material))
            opts.nmat = len(mats)
        else:
            x = 1e-5 if (k == "rmc" and v is True) else v
            try:
                x = float(x)
            except (TypeError, ValueError):
                raise ValueError("%s: expected a number, got %r" % (k, v)) from None
            if not math.isfinite(x):
                raise ValueError("%s: expected a finite number, got %r" % (k, v))
            setattr(opts, k, x)
    return opts, keep


def report_dict(r):
    """The members of the CLI's -json "levelset" object, from a CutReport."""
    return {"phi_min": r.phi_min, "phi_max": r.phi_max, "snapped": r.nsnapped,
            "removed_in": r.nremoved_in, "removed_out": r.nremoved_out,
            "edges_cut": r.ncut, "elements_cut": r.nelem_cut, "interface": r.niface,
            "dropped": r.ndropped, "boundary_with_interface_ref": r.nbdry_iface,
            "volume_in": r.vol_in, "volume_out": r.vol_out}


def cut_in_place(h, nvert, phi, **kw):
    """Cut the C mesh h (nvert vertices) by phi; returns the report dict."""
    phi = as_float("levelset", phi, (nvert,))
    opts, keep = options(**kw)
    rep = CutReport()
    check(lib.pa_mesh_levelset_cut(h, _lib.ptr(phi), ctypes.byref(opts), ctypes.byref(rep)))
    del keep
    return report_dict(rep)


def cut(mesh, phi, **kw):
    """Cut the zero set of phi - value into a copy of mesh (not modified).

    mesh     a padapt.Mesh
    phi      (nvert,) the level set at the vertices (any sign convention:
             the inside is phi < value)
    value    the iso-value (default 0)
    ref_in, ref_out, ref_iface  references of the inside elements, the
             outside ones and the interface's boundary entities and
             vertices (default 3, 2, 10)
    materials  Mmg's LSReferences: [(ref, ref_in, ref_out), (ref, None),
             ...]: the elements of each reference split into two, or kept
             whole; every element reference must be listed
    rmc      remove the components of either side smaller than this share
             of the mesh volume (True: Mmg's 1e-5)

    Returns (new Mesh, report): report is a dict (edges_cut, interface,
    volume_in, ...); report["interface"] == 0 when phi does not cross the
    mesh. Raises ValueError for a value that is not finite or bad options,
    padapt.Error when the library refuses (a reference the materials do
    not list, ...).
    """
    if not isinstance(mesh, Mesh):
        raise TypeError("levelset.cut: mesh must be a padapt.Mesh, got %s" % type(mesh).__name__)
    out = mesh.copy()
    rep = cut_in_place(out._h, mesh.nvert, phi, **kw)
    return out, rep
