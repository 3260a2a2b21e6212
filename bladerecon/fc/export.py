# SPDX-License-Identifier: LGPL-2.1-or-later
"""STEP export, closed solids with planar end caps, and reading CAD files into a shape.

Units are millimetres throughout: STEP files are written with ``SI_UNIT(.MILLI.,.METRE.)``
and checked for it, whatever FreeCAD's STEP unit preference says.
"""
from __future__ import annotations

import os
import re
import tempfile
from typing import Any

import numpy as np

from bladerecon.core.geometry.bspline import evaluate_surface
from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import (check_file_target, check_input, os_error_message, shown, signals_held,
                                        write_problem)
from bladerecon.core.geometry.spline import BSplineSurface
from bladerecon.core.tolerances import PLANAR_TOL

from bladerecon.fc.convert import compound, make_face
from bladerecon.fc.freecad_env import import_freecad, stdout_to_stderr

__all__ = ["write_step", "make_solid", "read_shape", "end_section_flatness", "SHAPE_SUFFIXES"]

FreeCAD, Part = import_freecad()

SHAPE_SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep", ".brp", ".fcstd")

_MM_LENGTH_UNIT = re.compile(r"\(\s*LENGTH_UNIT\s*\(\s*\)\s*NAMED_UNIT\s*\(\s*\*\s*\)\s*SI_UNIT\s*\(\s*\.MILLI\.\s*,\s*\.METRE\.\s*\)\s*\)")
_FIX_TOL = 1e-7  # OpenCASCADE's Precision::Confusion, mm


def _occ_message(err: BaseException) -> str:
    """FreeCAD 0.20 wraps C++ exceptions in a dict; later versions in plain text."""
    arg = err.args[0] if err.args else err
    if isinstance(arg, dict):
        return shown(str(arg.get("swhat") or arg.get("sErrMsg") or arg), 200)
    return shown(str(arg).splitlines()[0], 200) if str(arg).strip() else type(err).__name__


# --------------------------------------------------------------------------- STEP writing
def _check_writable(path: str) -> str:
    """The folder to write ``path`` in; an existing device, FIFO, socket, link or folder at
    ``path`` is refused (a rename would replace it), as are a missing or unwritable folder."""
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise BladeReconError(f"cannot write {shown(path, 200)}: folder {shown(folder, 200)} does not exist")
    check_file_target(path, "cannot write")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise BladeReconError(f"cannot write {shown(path, 200)}: folder {shown(folder, 200)} is not writable")
    return folder


def _write_problem(folder: str, tmp: str, path: str) -> str | None:
    """The OS reason a STEP write into ``folder`` failed (disk full, read-only, ...), or None."""
    problem = write_problem(folder)  # (the partial file still takes its space: a full disk shows)
    try:
        os.remove(tmp)
    except OSError:
        pass
    return problem.replace(f" {shown(folder, 200)}:", f" {shown(path, 200)}:", 1) if problem else None


def _export_step(shape: Any, path: str) -> None:
    """Write ``shape`` to ``path`` in millimetres, restoring FreeCAD's unit setting after."""
    units = getattr(Part, "exportUnits", None)
    previous = units().get("write.step.unit") if units else None
    try:
        if units:
            units("MM")
        with stdout_to_stderr():
            shape.exportStep(path)
    finally:
        if units and previous and previous != "MM":
            units(previous)


def _is_millimetre_step(path: str) -> bool:
    with open(path, "r", encoding="latin-1") as f:
        text = f.read()
    return bool(_MM_LENGTH_UNIT.search(text)) and "CONVERSION_BASED_UNIT" not in text


def write_step(shape: Any, path: str | os.PathLike) -> None:
    """Write a shape (or a core :class:`BSplineSurface`) to a STEP file in millimetres.

    Atomic: the file is written to a temporary name in the same folder and moved over
    ``path`` only when complete, so a failed export leaves any existing file untouched
    and no partial file behind.
    """
    path = os.fspath(path)
    if isinstance(shape, BSplineSurface):
        shape = make_face(shape)
    if shape is None or shape.isNull():
        raise BladeReconError(f"cannot write {path}: the shape is empty")
    folder = _check_writable(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".part", dir=folder)
    except OSError as err:
        raise BladeReconError(os_error_message(err, path)) from None
    os.close(fd)
    try:
        try:
            _export_step(shape, tmp)
        except (OSError, RuntimeError, Part.OCCError) as err:
            # OpenCASCADE says only "failed": a full disk or a lost share is told as such
            raise BladeReconError(_write_problem(folder, tmp, path)
                                  or f"cannot write {shown(path, 200)}: OpenCASCADE failed ({_occ_message(err)})") from None
        if os.path.getsize(tmp) == 0:
            raise BladeReconError(_write_problem(folder, tmp, path)
                                  or f"cannot write {shown(path, 200)}: OpenCASCADE wrote nothing")
        if not _is_millimetre_step(tmp):
            raise BladeReconError(f"cannot write {path}: the STEP writer did not use millimetres")
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


# --------------------------------------------------------------------------- solids
def _plane_fit(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares plane (centre, unit normal) and the largest distance of a point from it."""
    centre = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centre, full_matrices=False)
    normal = vt[2]
    return centre, normal, float(np.abs((points - centre) @ normal).max())


def _boundary_samples(surface: BSplineSurface, v: float) -> np.ndarray:
    """Points of the iso-curve S(u, v) around the section: 16 per knot span, at least 400."""
    n = max(400, 16 * (len(surface.u_knots) - 1))
    u0, u1 = surface.u_domain
    u = np.linspace(u0, u1, n, endpoint=False)
    return evaluate_surface(surface, u, np.full(n, v))


def end_section_flatness(surface: BSplineSurface) -> dict[str, float]:
    """Largest out-of-plane distance (mm) of the hub (v start) and tip (v end) boundary curves."""
    v0, v1 = surface.v_domain
    return {name: _plane_fit(_boundary_samples(surface, v))[2] for name, v in (("hub", v0), ("tip", v1))}


def _cap(edge: Any, samples: np.ndarray) -> Any:
    """Planar face bounded by ``edge``: exact plane if OCC finds one, else the fitted plane."""
    wire = Part.Wire([edge])
    try:
        face = Part.Face(wire)
        if face.isValid() and isinstance(face.Surface, Part.Plane):
            return face
    except Part.OCCError:
        pass
    centre, normal, deviation = _plane_fit(samples)
    face = Part.Face(Part.Plane(FreeCAD.Vector(*centre), FreeCAD.Vector(*normal)), wire)
    # the edge lies within `deviation` of the plane: say so in its tolerance
    face.fixTolerance(deviation * 1.01 + _FIX_TOL)
    return face


def _end_edges(face: Any, ends: list[np.ndarray]) -> list[Any]:
    """The closed boundary edges of a u-periodic face, in the order of ``ends`` (sampled curves)."""
    loops = [e for e in face.Edges if e.isClosed() and not e.Degenerated]
    if len(loops) != len(ends):
        raise BladeReconError(
            f"cannot close the surface: expected {len(ends)} closed end sections, found {len(loops)}"
        )
    picked = []
    for samples in ends:
        gaps = [np.linalg.norm(samples - np.array(tuple(e.valueAt(e.FirstParameter))), axis=1).min() for e in loops]
        picked.append(loops[int(np.argmin(gaps))])
    return picked


def make_solid(surface: BSplineSurface, planar_tol: float = PLANAR_TOL) -> Any:
    """Closed ``Part.Solid`` from a surface periodic in u, capped by planar faces at both ends in v.

    Each end section (v start = hub, v end = tip) must be planar within ``planar_tol`` mm,
    checked on samples of the boundary curve. The result is checked valid and closed and
    oriented so that its volume is positive.
    """
    if not surface.u_periodic:
        raise BladeReconError("cannot make a solid: the surface is not closed around the section (not periodic in u)")
    v_ends: list[tuple[str, np.ndarray]] = []
    if not surface.v_periodic:
        for name, v in zip(("hub", "tip"), surface.v_domain):
            samples = _boundary_samples(surface, v)
            deviation = _plane_fit(samples)[2]
            if deviation > planar_tol:
                raise BladeReconError(
                    f"the {name} end section is not planar (max out-of-plane {deviation:.3g} mm > "
                    f"{planar_tol:g} mm): export without --solid"
                )
            v_ends.append((name, samples))
    try:
        solid = _capped_solid(surface, v_ends)
    except (RuntimeError, ValueError, Part.OCCError) as err:  # OCC's builders and fixers refuse in these
        raise BladeReconError(f"cannot make a solid: OpenCASCADE refused the capped surface ({_occ_message(err)}): "
                              "export without --solid") from None
    if not (solid.isValid() and solid.isClosed() and solid.Volume > 0):
        raise BladeReconError(
            "the closed solid failed OpenCASCADE's validity check (self-intersecting surface?): export without --solid"
        )
    return solid


def _capped_solid(surface: BSplineSurface, v_ends: list[tuple[str, np.ndarray]]) -> Any:
    lateral = make_face(surface)
    faces = [lateral]
    if v_ends:  # a surface periodic in v too (a torus) is closed already
        edges = _end_edges(lateral, [s for _, s in v_ends])
        faces += [_cap(edge, samples) for edge, (_, samples) in zip(edges, v_ends)]
    shell = Part.Shell(faces)
    shell.fix(_FIX_TOL, _FIX_TOL, _FIX_TOL)  # ShapeFix_Shell: consistent face orientation
    if not shell.isClosed():
        raise BladeReconError("cannot make a solid: the capped surface is not closed (a cap does not meet the surface)")
    solid = Part.Solid(shell)
    solid.fix(_FIX_TOL, _FIX_TOL, _FIX_TOL)  # ShapeFix_Solid: outward orientation
    if solid.Volume < 0:
        solid.reverse()
    return solid


# --------------------------------------------------------------------------- reading
def _open_document(path: str) -> tuple[Any, bool]:
    """The document for ``path`` and whether we opened it (and so must close it)."""
    target = os.path.realpath(path)
    for doc in FreeCAD.listDocuments().values():
        if doc.FileName and os.path.realpath(doc.FileName) == target:
            return doc, False
    before = set(FreeCAD.listDocuments())
    try:
        try:
            return FreeCAD.openDocument(path, True), True  # hidden: no 3D view in the GUI
        except TypeError:  # a FreeCAD without the `hidden` argument
            return FreeCAD.openDocument(path), True
    except Exception:
        # a failed load keeps the half-made document alive: close it
        for name in set(FreeCAD.listDocuments()) - before:
            FreeCAD.closeDocument(name)
        raise


def _is_shown_part(obj: Any) -> bool:
    if not obj.isDerivedFrom("Part::Feature") or not getattr(obj, "Visibility", True):
        return False
    parent = obj.getParentGeoFeatureGroup() if hasattr(obj, "getParentGeoFeatureGroup") else None
    # features inside a PartDesign Body are represented by the Body's own shape
    return parent is None or not parent.isDerivedFrom("PartDesign::Body")


def _read_fcstd(path: str) -> Any:
    with stdout_to_stderr():
        doc, opened = _open_document(path)
    try:
        shapes = []
        for obj in doc.Objects:
            if _is_shown_part(obj) and not obj.Shape.isNull():
                shape = obj.Shape.copy()
                if hasattr(obj, "getGlobalPlacement"):
                    shape.Placement = obj.getGlobalPlacement()
                shapes.append(shape)
        return compound(shapes)
    finally:
        if opened:
            FreeCAD.closeDocument(doc.Name)


def read_shape(path: str | os.PathLike) -> Any:
    """Read a STEP, IGES, BREP or FCStd file (millimetres) into one ``Part.Shape``.

    For FCStd, the shapes of the visible Part features are combined into a compound.
    Raises :class:`BladeReconError` naming the file when it is missing, unreadable,
    empty or holds no faces.
    """
    path = os.fspath(path)
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in SHAPE_SUFFIXES:
        raise BladeReconError(
            f"cannot read {path}: unknown file type '{suffix}' (use .step/.stp, .iges/.igs, .brep/.brp or .FCStd)"
        )
    if not os.path.lexists(path):
        raise BladeReconError(f"cannot read {path}: file not found")
    check_input(path, "cannot read")
    if not os.access(path, os.R_OK):
        raise BladeReconError(f"cannot read {path}: permission denied")
    if os.path.getsize(path) == 0:
        raise BladeReconError(f"cannot read {path}: the file is empty")
    st = os.stat(path)
    key = (os.path.realpath(path), st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)
    if key in _READ_CACHE:          # one command reads its nominal once, however many steps use it
        _READ_CACHE[key] = _READ_CACHE.pop(key)
        return _READ_CACHE[key].copy()
    try:
        with signals_held():            # interrupted, OCC's reader threads crash: Ctrl-C comes after
            if suffix == ".fcstd":
                shape = _read_fcstd(path)
            else:
                with stdout_to_stderr():
                    shape = Part.Shape()
                    shape.read(path)
    except Exception as err:  # FreeCAD raises OSError, RuntimeError or its own types
        raise BladeReconError(f"cannot read {path}: {_occ_message(err)}") from None
    if shape.isNull() or not shape.Faces:
        what = "nothing" if shape.isNull() else f"{len(shape.Edges)} edges, {len(shape.Vertexes)} vertices"
        raise BladeReconError(f"cannot use {path}: it holds no faces ({what})")
    _READ_CACHE[key] = shape.copy()     # a copy each way: a caller that moves its shape moves only its own
    while len(_READ_CACHE) > _READ_CACHE_SIZE:
        _READ_CACHE.pop(next(iter(_READ_CACHE)))
    return shape


# Shapes read, by file identity (path, device, inode, size, modification time): a file changed
# or replaced is read again. The few most recent only (a workbench session reads many files).
_READ_CACHE: dict = {}
_READ_CACHE_SIZE = 4
