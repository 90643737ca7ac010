"""padapt.adapt: sequential adaptation of a Mesh to a metric, and the Report
of what it did (the statistics `padapt adapt -json` writes, as a mapping)."""
import collections.abc
import ctypes
import json
import math

import numpy as np

from . import _lib
from ._lib import lib, check, Error
from .mesh import Mesh, as_metric, as_field, stats_dict, _num, _ratio, transfer_code, ELEMENT

__all__ = ["adapt", "AdaptResult", "Report", "remesh_options"]


def transfer_dict(t):
    """A pa_transfer_report as the "transfer" member of the -json report."""
    return {"nfield": t.nfield, "nfast": t.nfast, "nclip": t.nclip, "nout": t.nout,
            "defect": t.defect, "uncovered": t.uncovered, "lost": t.lost,
            "time_s": t.time_s, "cpu_s": t.cpu_s}


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


class AdaptResult(collections.namedtuple("AdaptResult", "mesh fields report")):
    """What adapt() returns: the adapted Mesh, the interpolated vertex
    fields {name: array} and the Report; cell_fields and boundary_fields
    are the mesh's element and boundary fields as carried ({name:
    array})."""
    __slots__ = ()

    @property
    def cell_fields(self):
        return self.mesh.cell_fields

    @property
    def boundary_fields(self):
        return self.mesh.boundary_fields

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
          hausd=None, fields=None, cell_fields=None, boundary_fields=None,
          transfer=None, levelset=None, levelset_options=None, **options):
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
    levelset (nvert,) a level set: its zero set is cut into the mesh first
             (Mmg's -ls: inside, phi < 0, reference 3, outside 2, the
             interface reference 10), then kept as a boundary by the
             adaptation; report["levelset"] says what the cut did
    levelset_options  {name: value} of padapt.levelset.cut (value, ref_in,
             ref_out, ref_iface, materials, rmc)
    cell_fields  {name: (nelem,) or (nelem, k), or (array, mode)} element
             fields to carry, besides the mesh's: by their transfer mode,
             "conservative" (default: the integral kept), "bounded" (also
             within the values each new element overlaps) or "nearest"
             (integer data keeps its values); docs/guide/fields.md
    boundary_fields  {name: (nbdry,) or (nbdry, k)} boundary fields to
             carry: a new boundary entity takes the values of the old one of
             the same reference nearest to it
    transfer {name: mode} transfer modes of element fields (the mesh's or
             cell_fields'), or one mode for all of them
    options  hgradreq (gradation from required entities, default 2.3),
             angle (ridge detection angle in degrees, default 45),
             no_angle, no_insert, no_swap, no_move, no_surf (booleans, as
             the command line's -nr, -noinsert, -noswap, -nomove, -nosurf),
             verbosity

    Returns AdaptResult(mesh, fields, report): the new Mesh (carrying the
    metric the remesher used, interpolated, and every field), the vertex
    fields as {name: array} (result.cell_fields, result.boundary_fields:
    the element and boundary fields), and a Report (report["transfer"]:
    what carrying the element fields did, its conservation
    defect included). A result that misses the target is still
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
    cflds = []
    for n, v in (cell_fields or {}).items():
        mode = None
        if isinstance(v, tuple):
            v, mode = v
        cflds.append((n, as_field(n, v, mesh.nelem)[0],
                      None if mode is None else transfer_code(n, mode)))
    bflds = [(n, as_field(n, v, mesh.nbdry)[0]) for n, v in (boundary_fields or {}).items()]
    if isinstance(transfer, str):
        tmodes = {None: transfer_code("transfer", transfer)}
    else:
        tmodes = {n: transfer_code(n, m) for n, m in (transfer or {}).items()}
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
    for name, val, code in cflds:
        out.add_cell_field(name, val)
        if code is not None:
            tmodes.setdefault(name, code)
    for name, val in bflds:
        out.add_boundary_field(name, val)
    names = list(out.cell_fields)
    for name, code in tmodes.items():
        ks = range(len(names)) if name is None else [names.index(name)] if name in names else []
        if not ks and name is not None:
            raise ValueError("transfer: no element field %r (element fields: %s)"
                             % (name, ", ".join(names) or "none"))
        for k in ks:
            check(lib.pa_mesh_set_field_transfer(out._h, ELEMENT, k, code))
    nelem0 = mesh.nelem
    lsrep = None
    if levelset is not None:
        from .levelset import cut_in_place
        lsrep = cut_in_place(out._h, nv, levelset, **(levelset_options or {}))

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
    if lsrep is not None:
        d["levelset"] = lsrep
    d["transfer"] = transfer_dict(rep.transfer)
    report = Report(d, describe(rep.fidelity))
    return AdaptResult(out, out.fields, report)
