"""padapt.adapt: sequential adaptation of a Mesh to a metric, and the Report
of what it did (the statistics `padapt adapt -json` writes, as a mapping)."""
import collections.abc
import ctypes
import json
import math

import numpy as np

from . import _lib
from ._lib import lib, check, Error
from .mesh import Mesh, as_metric, as_field, stats_dict, _num, _ratio

__all__ = ["adapt", "AdaptResult", "Report", "remesh_options"]


def fidelity_dict(f):
    """The fidelity members of the CLI's -json report, from a pa_fidelity."""
    if not f.measured:
        return {"outcome": "not measured"}
    u = f.used
    met = bool(lib.pa_stats_target_met(ctypes.byref(u)))
    limited = []
    if not f.target_met:
        if not met:
            limited.append("remesher")
        else:
            for bit, name in ((1, "hmin"), (2, "hmax"), (4, "gradation")):
                if f.changed & bit:
                    limited.append(name)
    return {
        "outcome": "success" if f.target_met else "target missed",
        "target_met": bool(f.target_met), "limited_by": limited,
        "metric_used": {
            "changed": bool(f.changed),
            "edge_in_range": _ratio(u.edge_hist[_lib.STATS_EDGE_NBIN - 1], u.nedge),
            "edge_min": _num(u.edge_min), "edge_max": _num(u.edge_max),
            "quality_worst": _num(u.qual_min),
            "quality_mean": _ratio(u.qual_sum, u.nelem), "target_met": met},
    }


def describe(f):
    buf = ctypes.create_string_buffer(512)
    lib.pa_fidelity_describe(ctypes.byref(f), buf, len(buf))
    return buf.value.decode(errors="replace")


class Report(collections.abc.Mapping):
    """What an adaptation did: a read-only mapping with the members of the
    command line's `-json` report (the statistics of the result measured in
    the caller's metric: "elements", "edge_in_range", "quality_worst", ...;
    "time_s", the remesher's counts, "outcome", "target_met", "limited_by",
    "metric_used", ...). Attributes: target_met (bool), description (the
    one-line outcome the command line prints); to_json() gives the JSON
    text."""

    def __init__(self, members, description):
        self._d = members
        self.description = description

    def __getitem__(self, k):
        return self._d[k]

    def __iter__(self):
        return iter(self._d)

    def __len__(self):
        return len(self._d)

    @property
    def target_met(self):
        """True when at least 90 % of the edges are in [0.7071, 1.4142) in
        the caller's metric and no quality is below 0.01."""
        return bool(self._d.get("target_met", False))

    def to_json(self, **kw):
        """The report as JSON text (keyword arguments go to json.dumps)."""
        return json.dumps(self._d, allow_nan=False, **kw)

    def __repr__(self):
        return "<padapt.Report %s>" % self.description


AdaptResult = collections.namedtuple("AdaptResult", "mesh fields report")
AdaptResult.__doc__ = """What adapt() returns: the adapted Mesh, the
interpolated vertex fields {name: array} and the Report."""

# Options of adapt() and DistributedMesh.adapt() that map onto pa_remesh_opts.
_REMESH_KEYS = ("hmin", "hmax", "hsiz", "hgrad", "hgradreq", "hausd", "angle",
                "no_angle", "no_insert", "no_swap", "no_move", "no_surf", "verbosity")


def remesh_options(opts, **kw):
    """Fill a RemeshOpts (defaults already set) from keyword arguments; None
    keeps the default. Unknown names raise TypeError, non-numbers
    ValueError."""
    for k, v in kw.items():
        if k not in _REMESH_KEYS:
            raise TypeError("unknown adaptation option %r (known: %s)" % (k, ", ".join(_REMESH_KEYS)))
        if v is None:
            continue
        if k.startswith("no_") or k == "verbosity":
            setattr(opts, k, int(v))
        else:
            try:
                x = float(v)
            except (TypeError, ValueError):
                raise ValueError("%s: expected a number, got %r" % (k, v)) from None
            if not math.isfinite(x):
                raise ValueError("%s: expected a finite number, got %r" % (k, v))
            setattr(opts, k, x)
    return opts


def adapt(mesh, metric=None, *, hsiz=None, hmin=None, hmax=None, hgrad=None,
          hausd=None, fields=None, **options):
    """Adapt a copy of mesh to a metric with the built-in remesher.

    mesh     a padapt.Mesh (not modified)
    metric   sizes (nvert,) or tensors (nvert, 3) in 2D / (nvert, 6) in 3D
             (m11 m12 m22 [m13 m23 m33]); None: the mesh's own metric, or
             hsiz
    hsiz     constant size; replaces the metric
    hmin, hmax  size bounds applied to the metric
    hgrad    gradation: bound on the size ratio along an edge of unit length
             (default 1.3; <= 1, e.g. -1: none)
    hausd    maximal distance of the new boundary to the reconstructed one
             (default 0.01)
    fields   {name: (nvert,) or (nvert, k)} vertex fields to interpolate
             onto the new mesh, besides those the mesh carries
    options  hgradreq (gradation from required entities, default 2.3),
             angle (ridge detection angle in degrees, default 45),
             no_angle, no_insert, no_swap, no_move, no_surf (booleans, as
             the command line's -nr, -noinsert, -noswap, -nomove, -nosurf),
             verbosity

    Returns AdaptResult(mesh, fields, report): the new Mesh (carrying the
    metric the remesher used, interpolated, and the fields), the fields as
    {name: array}, and a Report. A result that misses the target is still
    returned (report.target_met is False, report.description says what
    limited it). Raises ValueError on bad arrays or options before any
    library call, padapt.Error when the library refuses the mesh or the
    metric, or when the remesher fails. The GIL is released while the
    library runs.
    """
    if not isinstance(mesh, Mesh):
        raise TypeError("adapt: mesh must be a padapt.Mesh, got %s" % type(mesh).__name__)
    opts = _lib.RemeshOpts()
    lib.pa_remesh_opts_default(ctypes.byref(opts))
    remesh_options(opts, hsiz=hsiz, hmin=hmin, hmax=hmax, hgrad=hgrad, hausd=hausd, **options)
    dim, nv = mesh.dim, mesh.nvert
    met = None if metric is None else as_metric("metric", metric, dim, nv)
    flds = [(n,) + as_field(n, v, nv) for n, v in (fields or {}).items()]
    if hsiz is not None and opts.hsiz <= 0:
        raise ValueError("hsiz: expected a positive size, got %r" % (hsiz,))
    if met is None and opts.hsiz <= 0 and lib.pa_mesh_metric_ncomp(mesh._h) == 0:
        raise ValueError("adapt: no metric: give metric=... or hsiz=..., or set mesh.metric")

    out = mesh.copy()
    if met is not None:
        check(lib.pa_mesh_set_metric(out._h, met[1], _lib.ptr(met[0])))
    elif opts.hsiz > 0 and lib.pa_mesh_metric_ncomp(out._h) == 0:
        h = np.full(nv, opts.hsiz)
        check(lib.pa_mesh_set_metric(out._h, 1, _lib.ptr(h)))
    for name, val, nc in flds:
        out.add_field(name, val)
    nelem0 = mesh.nelem

    rep = _lib.RemeshReport()
    check(lib.pa_remesh(lib.pa_remesher_builtin(), out._h, ctypes.byref(opts), ctypes.byref(rep)))
    if rep.outcome == 2:
        msg = lib.pa_last_error().decode(errors="replace")
        lib.pa_clear_error()
        raise Error("adapt: the remesher failed (%s)" % (msg or "no detail"), "remesh failed", 0)
    if not rep.fidelity.measured:  # out of memory measuring: once more
        check(lib.pa_mesh_stats(out._h, ctypes.byref(rep.fidelity.user)))
    d = stats_dict(rep.fidelity.user)
    d.update({"time_s": rep.time_s, "remesh_cpu_s": rep.cpu_s,
              "peak_rss_bytes": lib.pa_peak_rss(),
              "peak_memory_bytes": lib.pa_memory_peak(),
              "remesher_outcome": _lib.REMESH_OUTCOMES.get(rep.outcome, "failed"),
              "nsplit": rep.nsplit, "ncollapse": rep.ncollapse, "nswap": rep.nswap,
              "nmove": rep.nmove, "npass": rep.npass,
              "elements_before": nelem0, "vertices_before": nv})
    d.update(fidelity_dict(rep.fidelity))
    report = Report(d, describe(rep.fidelity))
    return AdaptResult(out, out.fields, report)
