"""The C library seen through ctypes: loading, prototypes, structures, errors.

Nothing here is public API; padapt.Mesh, padapt.adapt, padapt.metric and
padapt.DistributedMesh are built on it. ctypes calls through a CDLL release
the GIL for the duration of every foreign call, so an adaptation running in
one Python thread does not stop the others.

Where the library comes from, first match wins:
  1. the PADAPT_LIB environment variable (path to libpadapt.so);
  2. the library directory written into _config.py by `cmake --install`;
  3. the build trees next to this package in a source checkout
     (build/lib, then build-dev/lib);
  4. the dynamic loader's search path (ctypes.util.find_library).
"""
import ctypes
import ctypes.util
import os

import numpy as np

__all__ = []

c_idx = ctypes.c_int32   # pa_idx
c_gid = ctypes.c_int64   # pa_gid
c_status = ctypes.c_int  # pa_status (enum)
c_dbl_p = ctypes.POINTER(ctypes.c_double)
c_idx_p = ctypes.POINTER(c_idx)


def _candidates():
    env = os.environ.get("PADAPT_LIB")
    if env:
        yield env
        return
    try:
        from . import _config  # written at install time
        yield os.path.join(_config.LIBDIR, "libpadapt.so")
    except ImportError:
        pass
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    for b in ("build", "build-dev"):
        yield os.path.join(root, b, "lib", "libpadapt.so")
    found = ctypes.util.find_library("padapt")
    if found:
        yield found


def _load():
    tried = []
    for path in _candidates():
        if os.path.sep in path and not os.path.exists(path):
            tried.append(path)
            continue
        # RTLD_GLOBAL: Open MPI's plugins, loaded later by MPI_Init, resolve
        # symbols of libmpi through the global namespace.
        return ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL), path
    raise ImportError("padapt: libpadapt.so not found (tried %s); build the "
                      "library (make build) or set PADAPT_LIB" % ", ".join(tried or ["nothing"]))


lib, LIBPATH = _load()

# ---------------------------------------------------------------- structures
STATS_EDGE_NBIN = 10
STATS_QUAL_NBIN = 5
ADAPT_MAX_ITERS = 64


class Stats(ctypes.Structure):
    _fields_ = [("dim", ctypes.c_int), ("has_metric", ctypes.c_int),
                ("nvert", c_gid), ("nelem", c_gid), ("nbdry", c_gid),
                ("volume", ctypes.c_double), ("ninverted", c_gid),
                ("valid", ctypes.c_int), ("nedge", c_gid),
                ("edge_min", ctypes.c_double), ("edge_max", ctypes.c_double),
                ("edge_sum", ctypes.c_double),
                ("edge_hist", c_gid * STATS_EDGE_NBIN),
                ("qual_min", ctypes.c_double), ("qual_max", ctypes.c_double),
                ("qual_sum", ctypes.c_double),
                ("qual_hist", c_gid * STATS_QUAL_NBIN),
                ("qual_above_05", c_gid), ("qual_above_012", c_gid)]


class Fidelity(ctypes.Structure):
    _fields_ = [("measured", ctypes.c_int), ("user", Stats), ("used", Stats),
                ("target_met", ctypes.c_int), ("changed", ctypes.c_uint)]


class RemeshOpts(ctypes.Structure):
    _fields_ = [(n, ctypes.c_double) for n in
                ("hmin", "hmax", "hsiz", "hgrad", "hgradreq", "hausd", "angle")] + \
               [(n, ctypes.c_int) for n in
                ("no_angle", "no_insert", "no_swap", "no_move", "no_surf",
                 "verbosity", "trusted", "no_stats")] + \
               [("progress", ctypes.c_void_p), ("progress_ctx", ctypes.c_void_p),
                ("local", ctypes.c_void_p), ("nlocal", ctypes.c_int),
                ("mem_mb", ctypes.c_double), ("geometry", ctypes.c_void_p)]


class TransferReport(ctypes.Structure):
    _fields_ = [("nfield", ctypes.c_int), ("nfast", ctypes.c_long),
                ("nclip", ctypes.c_long), ("nout", ctypes.c_long),
                ("defect", ctypes.c_double), ("uncovered", ctypes.c_double),
                ("lost", ctypes.c_double), ("time_s", ctypes.c_double),
                ("cpu_s", ctypes.c_double)]


class RemeshReport(ctypes.Structure):
    _fields_ = [("outcome", ctypes.c_int), ("nsplit", ctypes.c_long),
                ("ncollapse", ctypes.c_long), ("nswap", ctypes.c_long),
                ("nmove", ctypes.c_long), ("npass", ctypes.c_int),
                ("time_s", ctypes.c_double), ("cpu_s", ctypes.c_double),
                ("fidelity", Fidelity), ("transfer", TransferReport),
                ("nproject", ctypes.c_long), ("nproject_failed", ctypes.c_long),
                ("project_s", ctypes.c_double)]


# pa_geometry_ops: the caller's kernel (padapt.Geometry wraps Python callables)
GEOM_CLOSEST = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_int,
                                ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double))
GEOM_CURVATURE = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_int,
                                  ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double))


class GeometryOps(ctypes.Structure):
    _fields_ = [("closest", GEOM_CLOSEST), ("curvature", GEOM_CURVATURE)]


class GeometryReport(ctypes.Structure):
    _fields_ = [("nvert", c_idx), ("dist_max", ctypes.c_double),
                ("dist_mean", ctypes.c_double), ("worst", c_idx),
                ("worst_dim", ctypes.c_int), ("worst_tag", ctypes.c_int),
                ("seconds", ctypes.c_double)]


class HessianOpts(ctypes.Structure):
    _fields_ = [(n, ctypes.c_double) for n in
                ("p", "target", "err", "hmin", "hmax", "hgrad")] + \
               [("recovery", ctypes.c_int)]


class LevelsetOpts(ctypes.Structure):
    _fields_ = [(n, ctypes.c_double) for n in ("eps", "hmin", "hmax", "band", "hgrad")]


class AdaptIter(ctypes.Structure):
    _fields_ = [("iter", ctypes.c_int), ("ntagged", c_gid), ("nelem", c_gid),
                ("npieces", ctypes.c_int), ("nfailed", ctypes.c_int)] + \
               [(n, ctypes.c_double) for n in
                ("imbalance", "t_tag", "t_pieces", "t_gather", "t_remesh",
                 "t_reintegrate", "remesh_busy", "remesh_cpu")] + \
               [(n, ctypes.c_long) for n in ("nsplit", "ncollapse", "nswap", "nmove")] + \
               [(n, ctypes.c_double) for n in
                ("bytes_moved", "mem_tag", "mem_pieces", "mem_gather", "mem_remesh",
                 "mem_reintegrate", "mem_after")]


class AdaptOpts(ctypes.Structure):
    _fields_ = [("remesh", RemeshOpts), ("remesher", ctypes.c_void_p),
                ("mem_mb", ctypes.c_double), ("qual_threshold", ctypes.c_double),
                ("user_tags_only", ctypes.c_int), ("max_iter", ctypes.c_int),
                ("pieces_per_rank", ctypes.c_int), ("skin_layers", ctypes.c_int),
                ("skin_layers_later", ctypes.c_int),
                ("min_piece_work", ctypes.c_double),
                ("min_piece_ratio", ctypes.c_double),
                ("rebalance_tol", ctypes.c_double), ("rebalance", ctypes.c_int),
                ("check_pieces", ctypes.c_int), ("progress", ctypes.c_void_p),
                ("progress_ctx", ctypes.c_void_p),
                ("checkpoint_dir", ctypes.c_char_p)]


class AdaptReport(ctypes.Structure):
    _fields_ = [("nranks", ctypes.c_int), ("niter", ctypes.c_int),
                ("converged", ctypes.c_int), ("stalled", ctypes.c_int),
                ("nelem_initial", c_gid), ("nelem_final", c_gid),
                ("nvert_initial", c_gid), ("nvert_final", c_gid),
                ("ntagged_left", c_gid), ("npieces", ctypes.c_long),
                ("nfailed", ctypes.c_long)] + \
               [(n, ctypes.c_double) for n in
                ("time_total", "t_tag", "t_pieces", "t_gather", "t_remesh",
                 "t_reintegrate", "t_rebalance", "t_measure", "remesh_busy", "remesh_cpu")] + \
               [(n, ctypes.c_long) for n in ("nsplit", "ncollapse", "nswap", "nmove")] + \
               [("bytes_moved", ctypes.c_double)] + \
               [("peak_memory", ctypes.c_size_t), ("peak_rss", ctypes.c_size_t),
                ("niter_recorded", ctypes.c_int),
                ("iters", AdaptIter * ADAPT_MAX_ITERS), ("fidelity", Fidelity),
                ("transfer", TransferReport)]


class DmeshIter(ctypes.Structure):
    _fields_ = [("list", c_idx_p), ("first", c_idx), ("end", c_idx), ("pos", c_idx)]


# ---------------------------------------------------------------- prototypes
P = ctypes.c_void_p  # opaque handles (pa_mesh *, pa_dmesh *, ...)
PP = ctypes.POINTER(ctypes.c_void_p)
S = c_status
D = ctypes.c_double
I = ctypes.c_int
dbl = c_dbl_p
cstr = ctypes.c_char_p


def _proto(name, restype, *argtypes):
    f = getattr(lib, name)
    f.restype = restype
    f.argtypes = list(argtypes)


for _n, _r, _a in [
        ("pa_status_string", cstr, [I]), ("pa_last_error", cstr, []),
        ("pa_version", cstr, []),
        ("pa_clear_error", None, []),
        ("pa_memory_current", ctypes.c_size_t, []), ("pa_memory_peak", ctypes.c_size_t, []),
        ("pa_memory_reset_peak", None, []), ("pa_peak_rss", ctypes.c_size_t, []),
        ("pa_set_verbosity", None, [I]), ("pa_wtime", D, []),
        ("pa_mesh_create", S, [I, PP]), ("pa_mesh_destroy", None, [P]),
        ("pa_mesh_copy", S, [P, PP]), ("pa_mesh_dim", I, [P]),
        ("pa_mesh_nvert", c_idx, [P]), ("pa_mesh_nelem", c_idx, [P]),
        ("pa_mesh_nbdry", c_idx, [P]), ("pa_mesh_nedge", c_idx, [P]),
        ("pa_mesh_resize", S, [P, c_idx, c_idx, c_idx, c_idx]),
        ("pa_mesh_coords", P, [P]), ("pa_mesh_elems", P, [P]),
        ("pa_mesh_bdrys", P, [P]), ("pa_mesh_edges", P, [P]),
        ("pa_mesh_vert_refs", P, [P]), ("pa_mesh_elem_refs", P, [P]),
        ("pa_mesh_bdry_refs", P, [P]), ("pa_mesh_edge_refs", P, [P]),
        ("pa_mesh_vert_flags", P, [P]), ("pa_mesh_elem_flags", P, [P]),
        ("pa_mesh_bdry_flags", P, [P]), ("pa_mesh_edge_flags", P, [P]),
        ("pa_mesh_set_metric", S, [P, I, dbl]), ("pa_mesh_metric_ncomp", I, [P]),
        ("pa_mesh_metric", P, [P]),
        ("pa_mesh_add_field", S, [P, cstr, I, dbl]), ("pa_mesh_remove_field", S, [P, I]),
        ("pa_mesh_nfield", I, [P]),
        ("pa_mesh_field", S, [P, I, ctypes.POINTER(cstr), ctypes.POINTER(I), ctypes.POINTER(dbl)]),
        ("pa_mesh_add_field_at", S, [P, I, cstr, I, dbl]),
        ("pa_mesh_remove_field_at", S, [P, I, I]), ("pa_mesh_nfield_at", I, [P, I]),
        ("pa_mesh_field_at", S, [P, I, I, ctypes.POINTER(cstr), ctypes.POINTER(I),
                                 ctypes.POINTER(dbl)]),
        ("pa_mesh_set_field_transfer", S, [P, I, I, I]),
        ("pa_mesh_field_transfer", I, [P, I, I]),
        ("pa_transfer_parse", S, [cstr, ctypes.POINTER(I)]), ("pa_transfer_name", cstr, [I]),
        ("pa_mesh_nnames", I, [P]),
        ("pa_mesh_name", S, [P, I, ctypes.POINTER(I), ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(cstr)]),
        ("pa_mesh_add_name", S, [P, I, ctypes.c_int32, cstr]),
        ("pa_mesh_build_boundary", S, [P, ctypes.c_int32, c_idx_p]),
        ("pa_mesh_invalidate", None, [P]), ("pa_mesh_volume", D, [P]),
        ("pa_mesh_elem_quality", D, [P, c_idx]),
        ("pa_mesh_check", S, [P]), ("pa_mesh_memory_used", ctypes.c_size_t, [P]),
        ("pa_mesh_generate_box", S, [I, I, PP]),
        ("pa_metric_analytic", S, [P, cstr]), ("pa_mesh_metric_clamp", S, [P, D, D]),
        ("pa_mesh_recover", S, [P, dbl, I, I, dbl, dbl]),
        ("pa_metric_complexity", S, [P, I, dbl, ctypes.POINTER(D)]),
        ("pa_metric_hessian_opts_default", None, [ctypes.POINTER(HessianOpts)]),
        ("pa_metric_from_hessian", S, [P, dbl, I, ctypes.POINTER(HessianOpts), dbl]),
        ("pa_metric_scale_complexity", S, [P, I, dbl, D]),
        ("pa_metric_intersect_all", S, [I, I, c_idx, dbl, dbl, dbl]),
        ("pa_mesh_metric_grade", S, [P, D, D]),
        ("pa_levelset_analytic", S, [P, cstr, dbl]),
        ("pa_metric_levelset_opts_default", None, [ctypes.POINTER(LevelsetOpts)]),
        ("pa_metric_from_levelset", S, [P, dbl, ctypes.POINTER(LevelsetOpts), dbl]),
        ("pa_mesh_stats", S, [P, ctypes.POINTER(Stats)]),
        ("pa_stats_write_json", S, [ctypes.POINTER(Stats), cstr, cstr]),
        ("pa_stats_target_met", I, [ctypes.POINTER(Stats)]),
        ("pa_fidelity_describe", None, [ctypes.POINTER(Fidelity), ctypes.c_char_p, ctypes.c_size_t]),
        ("pa_mesh_read", S, [cstr, PP]), ("pa_mesh_write", S, [P, cstr, P]),
        ("pa_mesh_read_model", S, [cstr, PP]), ("pa_mesh_classified", I, [P]),
        ("pa_mesh_vert_entity_dims", P, [P]), ("pa_mesh_vert_entity_tags", P, [P]),
        ("pa_mesh_set_vertex_entities", S, [P, P, P]), ("pa_mesh_classify", S, [P]),
        ("pa_mesh_copy_model", S, [P, P]),
        ("pa_geometry_create", S, [ctypes.POINTER(GeometryOps), P, D, PP]),
        ("pa_geometry_read", S, [cstr, PP]), ("pa_geometry_destroy", None, [P]),
        ("pa_geometry_available", I, [ctypes.POINTER(cstr)]),
        ("pa_geometry_size", D, [P]),
        ("pa_geometry_closest", S, [P, I, I, dbl, dbl]),
        ("pa_geometry_check", S, [P, P, D, ctypes.POINTER(GeometryReport)]),
        ("pa_remesh_opts_default", None, [ctypes.POINTER(RemeshOpts)]),
        ("pa_remesher_builtin", P, []),
        ("pa_remesh", S, [P, P, ctypes.POINTER(RemeshOpts), ctypes.POINTER(RemeshReport)]),
        ("pa_adapt_opts_default", None, [ctypes.POINTER(AdaptOpts)]),
]:
    _proto(_n, _r, *_a)

STATUS = {0: "success"}
for _k in range(1, 11):
    STATUS[_k] = lib.pa_status_string(_k).decode()

REMESH_OUTCOMES = {0: "success", 1: "target missed", 2: "failed"}


def _defaults(cls, fill):
    """The library's defaults of an options struct (fill: its *_opts_default):
    the Python keyword arguments take them from here, so each default is
    spelled once, in padapt.h."""
    o = cls()
    fill(ctypes.byref(o))
    return o


REMESH_DEFAULTS = _defaults(RemeshOpts, lib.pa_remesh_opts_default)
HESSIAN_DEFAULTS = _defaults(HessianOpts, lib.pa_metric_hessian_opts_default)
LEVELSET_DEFAULTS = _defaults(LevelsetOpts, lib.pa_metric_levelset_opts_default)
ADAPT_DEFAULTS = _defaults(AdaptOpts, lib.pa_adapt_opts_default)


class Error(RuntimeError):
    """A padapt library call failed.

    str(err) is the library's message (pa_last_error(): it names the file
    and line, or the entity, at fault); err.status is the short name of the
    pa_status ("format error", "mesh error", ...) and err.code its value.
    """

    def __init__(self, message, status="internal error", code=10):
        super().__init__(message)
        self.status = status
        self.code = code


def check(st, what=""):
    """Raise Error carrying pa_last_error() when st is not PA_SUCCESS."""
    if st == 0:
        return
    msg = lib.pa_last_error().decode(errors="replace")
    lib.pa_clear_error()
    name = STATUS.get(st, "status %d" % st)
    if not msg:
        msg = "%s: %s" % (what or "padapt", name)
    raise Error(msg, name, st)


def ptr(a, ctype=ctypes.c_double):
    """A ctypes pointer to the data of a C-contiguous numpy array."""
    return a.ctypes.data_as(ctypes.POINTER(ctype))


class _Borrow(object):
    """Keeps the owner of C memory alive while a numpy view of it exists."""
    __slots__ = ("owner", "__array_interface__")


def view(owner, address, shape, dtype, writable=True):
    """A numpy array over C memory at address, which keeps owner alive."""
    dtype = np.dtype(dtype)
    n = int(np.prod(shape))
    if n == 0 or not address:
        return np.zeros(shape, dtype)
    b = _Borrow()
    b.owner = owner
    b.__array_interface__ = {"shape": tuple(shape), "typestr": dtype.str,
                             "data": (address, not writable), "version": 3}
    return np.asarray(b)
