# SPDX-License-Identifier: LGPL-2.1-or-later
"""Signed deviation of measured points from a nominal shape, with optional best-fit (mm, degrees).

Issue 4 §1-2, 5. For every point the closest point on the nominal (any face of a STEP,
IGES, BREP or FCStd shape) and the signed distance, + where material lies outside the
nominal (the outward normal at the foot):

* one untrimmed, non-rational B-spline face (a blade surface as CAD writes it) goes
  through the core's vectorised exact projection (seed 001 eq. 10 by Newton from a k-d
  tree start, :mod:`bladerecon.core.geometry.projection`): ~1M points in a few seconds;
* any other shape face by face, vectorised too (:mod:`bladerecon.core.geometry.faces`):
  B-spline faces restricted or trimmed by pcurves, planes, cylinders, cones, spheres, tori,
  surfaces of revolution and extrusion, offset surfaces - each surface projected once, the
  foot kept where it lies inside the face's trimming loops, else the nearest point of the
  face's boundary edges; the closest foot over all faces wins; where the feet of the two
  signs tie (a thin edge) or the foot is a vertex, the nominal solid decides the sign;
* a face no core model covers through OpenCASCADE's ``distToShape`` point by point, only
  for the points whose distance to the face's bounding box is less than their best
  distance so far. ``Nominal.face_methods`` names the way of every face.

Alignment (:func:`bladerecon.core.analysis.alignment.best_fit`) uses the same measure as its
``project`` callback. Points far from every face - wrong units or frame - are refused with
a hint before any of this work.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from bladerecon.core.analysis.alignment import Alignment, apply_transform, best_fit
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.projection import distance_stats, project_points_to_surface
from bladerecon.core.geometry.spline import BSplineSurface

from bladerecon.fc.freecad_env import import_freecad

__all__ = ["PointDeviation", "Nominal", "DeviationResult", "read_measured", "load_nominal",
           "check_units", "measure_deviation", "deviation_summary", "write_deviation_csv"]

FreeCAD, Part = import_freecad()

_NEAR = 0.01                # median distance under this fraction of the nominal's size: in place
_FAR = 0.1                  # ... above this: another frame (or units)
_UNIT_CHECK_POINTS = 500    # points used for that check
INSIDE_DEFLECTION = 1e-4    # tessellation of the solid for signs the normals cannot settle, x size
_SCALES = ((1 / 25.4, "the points look like inches: multiply them by 25.4"),
           (25.4, "the points look like millimetres against a nominal in inches: convert the nominal to mm"),
           (1000.0, "the points look like micrometres: divide them by 1000"),
           (0.001, "the points look like metres: multiply them by 1000"))


@dataclass(frozen=True)
class PointDeviation:
    """Per point: signed distance (mm, + outside), foot (m, 3), unit outward normal, face index,
    and the foot's (u, v) on its face where that is a core B-spline face (NaN elsewhere)."""

    signed: np.ndarray
    foot: np.ndarray
    normal: np.ndarray
    face: np.ndarray
    methods: tuple[str, ...]
    u: np.ndarray | None = None
    v: np.ndarray | None = None


@dataclass(frozen=True)
class DeviationResult:
    points: np.ndarray              # measured points after alignment (mm)
    deviation: PointDeviation
    alignment: Alignment | None
    stats: dict
    seconds: dict


# --------------------------------------------------------------------------- measured points
def read_measured(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray | None, tuple[str, ...]]:
    """Points (m, 3) mm from any file the foundation reads; section labels optional.

    Returns (points, section index per point or None for a cloud, section names).
    """
    from bladerecon.core.io.readers import read_points

    ps = read_points(path, require_sections=False)
    if not ps.structured:
        return np.asarray(ps.points, float), None, ()
    return np.asarray(ps.points, float), np.asarray(ps.section), ps.section_names


# --------------------------------------------------------------------------- nominal
def _core_surface(face: Any) -> BSplineSurface | None:
    """The face's surface as core data if it is an untrimmed non-rational B-spline, else None."""
    from bladerecon.fc.convert import from_part_surface
    from bladerecon.fc.occ_measure import _has_natural_bounds

    surf = face.Surface
    if type(surf).__name__ != "BSplineSurface" or surf.isURational() or surf.isVRational():
        return None
    if not _has_natural_bounds(face):
        return None
    return from_part_surface(surf)


class Nominal:
    """A nominal shape ready for measuring (mm).

    One untrimmed B-spline face (a blade surface as CAD writes it) is projected directly.
    Any other shape goes face by face through :func:`bladerecon.core.geometry.faces.measure_faces`
    (each face's surface as a core model with its trimming loops and boundary edges,
    :func:`bladerecon.fc.nominal_faces.core_faces`); a face no core model covers is measured
    by OpenCASCADE per point. ``face_methods`` says, per face, which way was used.
    ``core`` lists the faces on B-spline surfaces as (index, surface, outward sign), ``occ``
    the faces OpenCASCADE measures as (index, face, outward sign).
    """

    def __init__(self, shape: Any, name: str = "nominal"):
        from bladerecon.core.geometry.orientation import outward_sign
        from bladerecon.fc.occ_measure import _shape_outward_signs

        self.name = name
        faces = list(shape.Faces)
        if not faces:
            raise BladeReconError(f"{name}: the nominal holds no faces: export the blade surface, shell or solid")
        box = shape.BoundBox
        self.size = float(np.hypot(np.hypot(box.XLength, box.YLength), box.ZLength))
        self.centre = np.array([box.Center.x, box.Center.y, box.Center.z])
        self.core: list[tuple[int, BSplineSurface, float]] = []
        self.occ: list[tuple[int, Any, float]] = []
        self.faces: list = []
        self.edges: list = []
        self._inside: Any = None
        self._solid: Any = None
        self.seconds: dict = {}
        surf = _core_surface(faces[0]) if len(faces) == 1 else None
        if surf is not None:                      # one untrimmed B-spline face: the direct projection
            self.shape = shape
            if surf.u_periodic:
                sign = outward_sign(surf)                # a closed blade surface: normal out of the blade
            else:
                sign = ((-1.0 if faces[0].Orientation == "Reversed" else 1.0)
                        * float(_shape_outward_signs(shape, faces)[0]))
            self.core.append((0, surf, sign))
            self.face_methods: tuple[str, ...] = ("core-projection",)
            self.n_faces = 1
            return
        from bladerecon.fc.nominal_faces import core_faces

        shape = _closed_shape(shape)
        self.shape = shape
        faces = list(shape.Faces)
        occ_signs = _shape_outward_signs(shape, faces)
        self.faces, self.edges = core_faces(shape, occ_signs, self.size)
        for k, (f, face) in enumerate(zip(self.faces, faces)):
            if f.model is None:
                f.external = _occ_face_measurer(face, float(occ_signs[k]))
                self.occ.append((k, face, float(occ_signs[k])))
            elif f.method.startswith("core-bspline"):
                self.core.append((k, f.model.surface, f.sign))
        self.face_methods = tuple(f.method for f in self.faces)
        self._solid = shape if (shape.Solids or any(sh.isClosed() for sh in shape.Shells)) else None
        self.n_faces = len(faces)

    @property
    def methods(self) -> tuple[str, ...]:
        """Per face ``index:method`` (one face on the direct path: ``core-projection``)."""
        if not self.faces:
            return self.face_methods
        return tuple(f"{k}:{m}" for k, m in enumerate(self.face_methods))

    def inside(self, points: np.ndarray) -> np.ndarray:
        """True where points lie inside the nominal solid (ray parity on a tessellation made
        once, on the first call: linear deflection ``INSIDE_DEFLECTION`` of the size)."""
        if self._inside is None:
            from bladerecon.fc.nominal_faces import solid_inside

            self._inside = solid_inside(self._solid, INSIDE_DEFLECTION * max(self.size, 1.0))
        return self._inside(points)

    def measure(self, points: np.ndarray) -> PointDeviation:
        """Closest foot over all faces for each point (m, 3) mm."""
        P = np.asarray(points, dtype=float).reshape(-1, 3)
        m = len(P)
        if not self.faces:                                 # one B-spline face: nothing to choose between
            (k, surf, sign), = self.core
            pr = project_points_to_surface(surf, P)
            return PointDeviation(sign * pr.signed, pr.foot, sign * pr.normal, np.full(m, k), ("core-projection",),
                                  pr.u, pr.v)
        from bladerecon.core.geometry.faces import measure_faces

        scale = max(self.size, 1.0)
        feet = measure_faces(P, self.faces, self.edges, self.inside if self._solid is not None else None,
                             tie_tol=1e-6 * scale, inside_tol=2 * INSIDE_DEFLECTION * scale)
        self.seconds = feet.seconds
        return PointDeviation(feet.signed, feet.foot, feet.normal, feet.face, self.methods, feet.u, feet.v)

    def projector(self):
        """``project`` callback for :func:`best_fit`: (foot, outward normal)."""
        def project(P: np.ndarray):
            d = self.measure(P)
            return d.foot, d.normal
        return project


def _closed_shape(shape: Any) -> Any:
    """A compound of loose faces that sews into a closed shell (IGES) becomes a solid, outward."""
    if shape.Solids or any(sh.isClosed() for sh in shape.Shells) or len(shape.Faces) < 2:
        return shape
    try:
        sewn = shape.copy()
        sewn.sewShape()
        shells = sewn.Shells
        if len(shells) != 1 or not shells[0].isClosed() or len(shells[0].Faces) != len(shape.Faces):
            return shape
        solid = Part.Solid(shells[0])
        if solid.Volume < 0:
            solid.reverse()
        return solid if solid.isValid() else shape
    except Exception:                                      # noqa: BLE001 - unsewable: measure as given
        return shape


def _occ_face_measurer(f: Any, osign: float):
    """OpenCASCADE per point for one face: (P, best) -> distance (inf where not nearer than
    best), signed, foot, outward normal."""
    from bladerecon.fc.occ_measure import _normal_at_foot

    def measure(P: np.ndarray, best: np.ndarray):
        m = len(P)
        dist, signed = np.full(m, np.inf), np.zeros(m)
        foot, normal = np.zeros((m, 3)), np.zeros((m, 3))
        for i in range(m):
            d, pairs, infos = Part.Vertex(FreeCAD.Vector(*P[i])).distToShape(f)
            if d >= best[i]:
                continue
            ft = pairs[0][1]
            n, _ = _normal_at_foot(f, [f], infos[0], ft)
            n = np.array([n.x, n.y, n.z]) * osign
            n /= max(np.linalg.norm(n), 1e-300)
            off = P[i] - np.array([ft.x, ft.y, ft.z])
            dist[i], foot[i], normal[i] = d, (ft.x, ft.y, ft.z), n
            signed[i] = -d if off @ n < 0 else d
        return dist, signed, foot, normal

    return measure


def load_nominal(nominal: Any) -> Nominal:
    """A :class:`Nominal` from a path (STEP/IGES/BREP/FCStd) or a ``Part.Shape``."""
    from bladerecon.fc.export import read_shape

    if isinstance(nominal, (str, bytes)) or hasattr(nominal, "__fspath__"):
        return Nominal(read_shape(nominal), os.fspath(nominal))
    if nominal is None or nominal.isNull():
        raise BladeReconError("the nominal shape is empty")
    return Nominal(nominal)


# --------------------------------------------------------------------------- checks
_GRID = 33     # points a side of each face's parameter grid for blade_like_warning


def blade_like_warning(nominal: Nominal) -> str | None:
    """One line when the nominal does not look like a blade (its two opposite-facing sheets lie
    far apart for its size: a box, a cylinder given by mistake), else None. Judged on a
    _GRID x _GRID grid of points over each face's parameter range, triangulated (a mesh of
    the shape by OCC takes up to a minute on a 1500 x 16-pole face)."""
    from bladerecon.core.analysis.plausibility import BLADE_WALL_RATIO, wall_ratio

    verts, tris = [], []
    for face in nominal.shape.Faces:
        try:
            u0, u1, v0, v1 = face.ParameterRange
            us, vs = np.linspace(u0, u1, _GRID), np.linspace(v0, v1, _GRID)
            P = np.array([tuple(face.valueAt(u, v)) for u in us for v in vs])
        except Exception:                   # a face OCC cannot evaluate: judged without it
            continue
        k = np.arange(_GRID * _GRID).reshape(_GRID, _GRID)
        a, b, c, d = k[:-1, :-1].ravel(), k[1:, :-1].ravel(), k[1:, 1:].ravel(), k[:-1, 1:].ravel()
        t = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
        if face.Orientation == "Reversed":
            t = t[:, ::-1]
        tris.append(t + sum(len(x) for x in verts))
        verts.append(P)
    if not verts:
        return None
    ratio = wall_ratio(np.vstack(verts), np.vstack(tris))
    if not ratio > BLADE_WALL_RATIO:
        return None
    return (f"the nominal does not look like a blade: its opposite walls lie {ratio * 100:.0f} % of its size "
            f"apart (a blade's: under {BLADE_WALL_RATIO * 100:.0f} %); check --nominal")


def check_units(points: np.ndarray, nominal: Nominal, source: str = "the points") -> None:
    """Refuse points far from every face (wrong units or frame), saying which is likely.

    Points whose median distance is under 1 % of the nominal's size pass (even a single
    section). Farther, a point cloud 25.4x (or 1/25.4, 1000, 1/1000x) the nominal's size
    means wrong units; a median distance over 10 % of the size means another frame.
    """
    P = np.asarray(points, float)
    if len(P) == 0:
        raise BladeReconError(f"{source}: no points")
    rng = np.random.default_rng(0)
    sample = P if len(P) <= _UNIT_CHECK_POINTS else P[rng.choice(len(P), _UNIT_CHECK_POINTS, replace=False)]
    # cheap lower bound first: distance to the bounding box of the nominal
    box = nominal.shape.BoundBox
    lo, hi = np.array([box.XMin, box.YMin, box.ZMin]), np.array([box.XMax, box.YMax, box.ZMax])
    median = float(np.median(np.linalg.norm(np.maximum(0.0, np.maximum(lo - sample, sample - hi)), axis=1)))
    if median <= _NEAR * nominal.size:
        median = float(np.median(np.abs(nominal.measure(sample).signed)))
    if median <= _NEAR * nominal.size:
        return
    extent = float(np.linalg.norm(np.ptp(P, axis=0)))
    ratio = extent / max(nominal.size, 1e-300)
    hint = next((text for scale, text in _SCALES if abs(np.log(ratio / scale)) < np.log(1.15)), None)
    if hint is None and median <= _FAR * nominal.size:
        return                          # somewhat off: misplaced, which --align may correct
    if hint is None:
        hint = ("the points are the nominal's size but elsewhere: a different frame (origin or axes)? "
                "transform them into the nominal's frame")
    raise BladeReconError(
        f"{source}: points lie far from the nominal: median distance {median:.4g} mm is "
        f"{median / nominal.size:.3g}x the blade size ({nominal.size:.4g} mm); the point cloud "
        f"spans {ratio:.3g}x the blade size: {hint}")


# --------------------------------------------------------------------------- the run
def measure_deviation(points: np.ndarray, nominal: Nominal, align: str = "none",
                      tolerance: float = 0.03, source: str = "the points", robust: bool = False,
                      offset: float = 0.0, normals: np.ndarray | None = None) -> DeviationResult:
    """Align (``none|rigid|translate|rotate-z``; ``robust``: Tukey-biweight fit), then
    measure; stats as in ``deviation --json``.

    ``offset`` (mm, probe radius + coating): the points are first moved that far toward the
    material along the nominal's outward normal at their feet (the nominal-vector compensation
    of CMM software), then aligned and measured. ``normals`` (N, 3), the file's own unit normals
    (a CMM's i j k, a scanner's): the move is along them instead, each turned toward the side of
    the nominal's outward normal (a file may give them pointing in or out): the measured surface's
    normal where the part is twisted or bent off the nominal."""
    t0 = time.perf_counter()
    P = np.asarray(points, float)
    check_units(P, nominal, source)
    if offset:
        # along the nominal's normals at the feet; with a best fit asked for, the feet after a first
        # fit (a cloud in its own frame has no good feet before), normals taken back into its frame
        R = np.eye(3)
        Q = P
        if align != "none":
            M = best_fit(P, nominal.projector(), align, robust=robust).matrix
            Q, R = apply_transform(P, M), M[:3, :3]
        outward = nominal.measure(Q).normal @ R
        if normals is not None:
            given = np.asarray(normals, float)
            given = given / np.linalg.norm(given, axis=1)[:, None]     # within 1 % of unit as read: exactly
            outward = given * np.where(np.einsum("ij,ij->i", given, outward) < 0.0, -1.0, 1.0)[:, None]
        P = P - offset * outward
    t1 = time.perf_counter()
    alignment = None
    if align != "none":
        alignment = best_fit(P, nominal.projector(), align, robust=robust)
        P = apply_transform(P, alignment.matrix)
    t2 = time.perf_counter()
    dev = nominal.measure(P)
    t3 = time.perf_counter()
    stats = deviation_summary(dev.signed, tolerance)
    return DeviationResult(P, dev, alignment, stats,
                           {"check": t1 - t0, "align": t2 - t1, "measure": t3 - t2, "total": t3 - t0})


def deviation_summary(signed: np.ndarray, tolerance: float) -> dict:
    """max/min/mean/std/rms of the signed deviations (mm) and % of points within ±tolerance.

    ``max``/``min`` are the signed extremes; ``mean``/``std`` of the signed values (a bias
    shows as the mean); ``rms`` and ``max_abs``/``mean_abs`` as seed 000 Table 1.
    """
    d = np.asarray(signed, float)
    if tolerance <= 0:
        raise BladeReconError(f"--tolerance {tolerance}: give a positive tolerance in mm")
    mag = distance_stats(d, signed=True)
    return {"points": int(d.size), "max": float(d.max()), "min": float(d.min()), "mean": float(d.mean()),
            "std": float(d.std()), "rms": mag["rms"], "max_abs": mag["max"], "mean_abs": mag["mean"],
            "tolerance": float(tolerance),
            "within_tolerance_pct": float(100.0 * np.mean(np.abs(d) <= tolerance))}


_CSV_BLOCK = 16_384      # rows formatted at a time by write_deviation_csv
_CSV_SPLIT = 200_000     # from this many rows the second half is formatted by a forked child


def write_deviation_csv(path: str, points: np.ndarray, dev: PointDeviation) -> None:
    """``x,y,z,deviation,nx,ny,nz,face`` per point (mm; face 0-based), written atomically.

    Lengths and normal components with 7 decimals (0.1 nm), formatted by numpy
    (:mod:`bladerecon.core.io.csv_rows`: 1M rows in ~0.6 s instead of ~1.3 s); values that
    cannot be (not finite, beyond 4.5e8 mm) are written with ``%.9g`` instead. From
    ``_CSV_SPLIT`` rows, where a fork is safe, a forked child formats the second half into a
    hidden file beside the target while this process formats the first; the two are joined
    (a child that fails has its half formatted here). The file is the same either way."""
    import shutil
    import tempfile

    from bladerecon.core.geometry.projection.parallel import _can_fork, _fork_blocks

    path = os.path.abspath(path)
    n = len(points)
    fd, tmp = tempfile.mkstemp(prefix=".deviations-", suffix=".csv", dir=os.path.dirname(path))
    part = None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(b"x,y,z,deviation,nx,ny,nz,face\n")
            if n >= _CSV_SPLIT and _can_fork():
                pfd, part = tempfile.mkstemp(prefix=".deviations-", suffix=".part", dir=os.path.dirname(path))
                os.close(pfd)
                half = (n // 2) // _CSV_BLOCK * _CSV_BLOCK     # the same blocks as one process: the same text

                def work(s: int, e: int, _workers: int) -> None:
                    if s == 0:
                        _write_rows(fh, points, dev, s, e)
                    else:                   # the child's half, or the parent's after a failed child
                        with open(part, "wb") as ph:
                            _write_rows(ph, points, dev, s, e)

                _fork_blocks([[(0, half)], [(half, n)]], work)
                with open(part, "rb") as ph:
                    shutil.copyfileobj(ph, fh, 1 << 22)
            else:
                _write_rows(fh, points, dev, 0, n)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    finally:
        if part is not None and os.path.exists(part):
            os.unlink(part)


def _write_rows(fh, points: np.ndarray, dev: PointDeviation, start: int, stop: int) -> None:
    """Rows ``start:stop`` of the deviation table, ``_CSV_BLOCK`` rows of text in memory at a time."""
    from bladerecon.core.io.csv_rows import can_format, format_rows

    row = "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%d\n"
    decimals = [7] * 7 + [0]
    for s in range(start, stop, _CSV_BLOCK):
        e = min(s + _CSV_BLOCK, stop)
        columns = [points[s:e, 0], points[s:e, 1], points[s:e, 2], dev.signed[s:e],
                   dev.normal[s:e, 0], dev.normal[s:e, 1], dev.normal[s:e, 2], dev.face[s:e]]
        if can_format(columns, decimals):
            fh.write(format_rows(columns, decimals))
        else:
            block = np.column_stack(columns)
            fh.write(((row * (e - s)) % tuple(block.ravel().tolist())).encode("ascii"))
