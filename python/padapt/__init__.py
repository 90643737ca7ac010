"""padapt: parallel mesh adaptation (2D triangles, 3D tetrahedra) to a metric.

A Python package over the C library libpadapt, through ctypes (no compiled
extension). Sequential:

    mesh = padapt.read("in.mesh")                  # or padapt.Mesh(points, cells, ...)
    new, fields, report = padapt.adapt(mesh, metric, hmax=0.1, fields={"u": u})
    new.write("out.mesh")

Metric toolbox: padapt.metric (hessian, levelset, signed_distance,
intersect, grade, clamp, complexity, ...). A level set cut into the mesh
(Mmg's -ls): padapt.levelset.cut, or padapt.adapt(..., levelset=phi). Distributed, under mpiexec with
mpi4py: padapt.DistributedMesh. Errors of the library raise padapt.Error
carrying its message; bad arrays raise ValueError before any library call.
See docs/guide/python.md.
"""
from ._lib import Error, LIBPATH as _LIBPATH, lib as _clib
from .mesh import Mesh, read, FLAG_CORNER, FLAG_RIDGE, FLAG_REQUIRED, FLAG_USER
from .adapt import adapt, AdaptResult, Report
from . import metric
from . import levelset

__version__ = _clib.pa_version().decode()  # the library's (padapt.h)
__all__ = ["Error", "Mesh", "read", "adapt", "AdaptResult", "Report", "metric", "levelset",
           "DistributedMesh", "FLAG_CORNER", "FLAG_RIDGE", "FLAG_REQUIRED",
           "FLAG_USER", "library_path", "memory_current", "memory_peak"]


def library_path():
    """Path of the libpadapt.so this package uses."""
    return _LIBPATH


def memory_current():
    """Bytes currently allocated by the library in this process."""
    from ._lib import lib
    return lib.pa_memory_current()


def memory_peak():
    """Peak of memory_current() since the start of the process."""
    from ._lib import lib
    return lib.pa_memory_peak()


def __getattr__(name):
    # DistributedMesh imports mpi4py (which starts MPI): only on first use.
    if name == "DistributedMesh":
        from .distributed import DistributedMesh
        return DistributedMesh
    raise AttributeError("module 'padapt' has no attribute %r" % name)
