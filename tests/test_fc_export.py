# SPDX-License-Identifier: LGPL-2.1-or-later
"""bladerecon.fc.export: STEP in millimetres written atomically, capped solids, reading CAD files."""
from __future__ import annotations

import os

import numpy as np
import pytest

from bladerecon.core.geometry.bspline import curve_derivatives, evaluate_surface
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface
from fc_fixtures import blade_surface, clamped_surface, tapered_tube, require_freecad

FreeCAD, Part = require_freecad()

from bladerecon.fc import export  # noqa: E402
from bladerecon.fc.convert import make_face  # noqa: E402
from bladerecon.fc.export import end_section_flatness, make_solid, read_shape, write_step  # noqa: E402


def _gauss_integral(f, knots, order=8):
    """Integral of f over [knots[0], knots[-1]], Gauss-Legendre on each knot span (exact for
    piecewise polynomials of degree < 2 * order)."""
    x, w = np.polynomial.legendre.leggauss(order)
    total = 0.0
    for a, b in zip(knots[:-1], knots[1:]):
        if b > a:
            t = 0.5 * (b - a) * x + 0.5 * (a + b)
            total += 0.5 * (b - a) * np.sum(w * f(t))
    return total


def tube_volume(s: BSplineSurface) -> float:
    """Exact volume of ``tapered_tube``: V = A0 * integral of s(v)^2 z'(v) dv, where A0 is the
    area of the base section C(u) (Green: A0 = 1/2 integral of x y' - y x' du)."""
    base = s.poles[:, 0, :2] / 1.0
    section = BSplineCurve(base, s.u_knots, s.u_mults, s.u_degree, True)

    def green(u):
        d = curve_derivatives(section, u, 1)
        return 0.5 * (d[:, 0, 0] * d[:, 1, 1] - d[:, 0, 1] * d[:, 1, 0])

    area0 = _gauss_integral(green, s.u_knots)
    scale = np.linalg.norm(s.poles[0, :, :2], axis=1) / np.linalg.norm(s.poles[0, 0, :2])
    axis = BSplineCurve(np.column_stack([scale, s.poles[0, :, 2]]), s.v_knots, s.v_mults, s.v_degree, False)

    def slab(v):
        d = curve_derivatives(axis, v, 1)
        return d[:, 0, 0] ** 2 * d[:, 1, 1]

    return area0 * _gauss_integral(slab, s.v_knots)


def split_volume(solid) -> float:
    """OCC volume with the B-spline face cut at every knot line, so that OCC's fixed Gauss
    rule integrates single polynomial patches (much closer to exact than ``solid.Volume``)."""
    pieces = []
    for face in solid.Faces:
        surface = face.Surface
        if not isinstance(surface, Part.BSplineSurface):
            pieces.append(face)
            continue
        uk, vk = surface.getUKnots(), surface.getVKnots()
        for u0, u1 in zip(uk[:-1], uk[1:]):
            for v0, v1 in zip(vk[:-1], vk[1:]):
                patch = surface.copy()
                patch.segment(u0, u1, v0, v1)
                piece = Part.Face(patch)
                if face.Orientation == "Reversed":
                    piece.reverse()
                pieces.append(piece)
    return Part.Compound(pieces).Volume


# --------------------------------------------------------------------------- STEP
@pytest.mark.parametrize("kind", ["periodic_u", "clamped"])
def test_step_round_trip(tmp_path, kind):
    s = blade_surface() if kind == "periodic_u" else clamped_surface()
    path = tmp_path / "blade.step"
    write_step(make_face(s), path)
    text = path.read_text(encoding="latin-1")
    assert "SI_UNIT(.MILLI.,.METRE.)" in text and "B_SPLINE_SURFACE" in text
    shape = read_shape(path)
    assert len(shape.Faces) == 1
    face = shape.Faces[0]
    assert isinstance(face.Surface, Part.BSplineSurface)
    rng = np.random.default_rng(0)
    u = rng.uniform(*s.u_domain, 2000)
    v = rng.uniform(*s.v_domain, 2000)
    occ = np.array([tuple(face.Surface.value(a, b)) for a, b in zip(u, v)])
    assert np.abs(occ - evaluate_surface(s, u, v)).max() <= 1e-6
    assert abs(face.Area - make_face(s).Area) <= 1e-6 * face.Area


def test_write_step_accepts_a_core_surface_and_leaves_no_temp_files(tmp_path):
    write_step(clamped_surface(), str(tmp_path / "sheet.stp"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sheet.stp"]
    assert oct(os.stat(tmp_path / "sheet.stp").st_mode & 0o777) != "0o600"


def test_step_is_millimetres_whatever_the_unit_preference(tmp_path):
    if not hasattr(Part, "exportUnits"):
        pytest.skip("this FreeCAD has no Part.exportUnits")
    Part.exportUnits("INCH")
    try:
        write_step(Part.makeBox(10, 20, 30), tmp_path / "box.step")
        assert Part.exportUnits()["write.step.unit"] == "INCH"  # the user's setting is restored
    finally:
        Part.exportUnits("MM")
    text = (tmp_path / "box.step").read_text(encoding="latin-1")
    assert "CONVERSION_BASED_UNIT" not in text
    assert abs(read_shape(tmp_path / "box.step").Volume - 6000.0) < 1e-6


def test_failed_write_leaves_the_target_unchanged(tmp_path, monkeypatch):
    target = tmp_path / "blade.step"
    target.write_text("previous good export\n")

    def half_write(shape, path):
        with open(path, "w") as f:
            f.write("ISO-10303-21;\nHEADER;\n")  # cut off mid-file
        raise RuntimeError("disk full")

    monkeypatch.setattr(export, "_export_step", half_write)
    with pytest.raises(BladeReconError, match="disk full"):
        write_step(Part.makeBox(1, 1, 1), target)
    assert target.read_text() == "previous good export\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blade.step"]


def test_write_step_reports_bad_folders(tmp_path):
    with pytest.raises(BladeReconError, match="does not exist"):
        write_step(Part.makeBox(1, 1, 1), tmp_path / "no_such_dir" / "b.step")
    with pytest.raises(BladeReconError, match="is a folder"):
        write_step(Part.makeBox(1, 1, 1), tmp_path)
    with pytest.raises(BladeReconError, match="empty"):
        write_step(Part.Shape(), tmp_path / "b.step")


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_write_step_reports_an_unwritable_folder(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        with pytest.raises(BladeReconError, match="not writable"):
            write_step(Part.makeBox(1, 1, 1), locked / "b.step")
    finally:
        locked.chmod(0o700)


# --------------------------------------------------------------------------- solids
def test_make_solid_of_a_tube_with_planar_ends():
    s = tapered_tube()
    solid = make_solid(s)
    assert solid.ShapeType == "Solid" and len(solid.Faces) == 3
    assert solid.isValid() and solid.isClosed()
    expected = tube_volume(s)
    assert expected > 0
    # OCC's default mass integration uses few Gauss points per face: 0.5 % off here
    assert solid.Volume == pytest.approx(expected, rel=1e-2)
    assert split_volume(solid) == pytest.approx(expected, rel=1e-4)


def test_make_solid_is_outward_even_for_a_clockwise_section():
    s = tapered_tube()
    flipped = BSplineSurface(s.poles[::-1].copy(), (1 - s.u_knots)[::-1].copy(), s.u_mults[::-1].copy(),
                             s.v_knots, s.v_mults, s.u_degree, s.v_degree, True, False)
    solid = make_solid(flipped)
    assert tube_volume(flipped) < 0  # the section runs clockwise
    assert solid.isValid() and split_volume(solid) == pytest.approx(-tube_volume(flipped), rel=1e-4)


def test_make_solid_of_a_twisted_blade_with_planar_ends():
    s = blade_surface()
    poles = s.poles.copy()
    poles[:, 0, 2] = 0.0  # hub and tip pole rows in planes z = 0 and z = 90
    poles[:, -1, 2] = 90.0
    s = BSplineSurface(poles, s.u_knots, s.u_mults, s.v_knots, s.v_mults, 3, 3, True, False)
    solid = make_solid(s)
    assert solid.isValid() and solid.isClosed() and solid.Volume > 0


def test_make_solid_accepts_ends_planar_within_tolerance():
    s = tapered_tube()
    rng = np.random.default_rng(5)
    poles = s.poles.copy()
    poles[:, 0, 2] += rng.uniform(-0.004, 0.004, len(poles))
    s = BSplineSurface(poles, s.u_knots, s.u_mults, s.v_knots, s.v_mults, 3, 3, True, False)
    assert 0 < end_section_flatness(s)["hub"] <= 0.01
    solid = make_solid(s, planar_tol=0.01)
    assert solid.isValid() and solid.isClosed()
    assert split_volume(solid) == pytest.approx(tube_volume(tapered_tube()), rel=1e-3)


@pytest.mark.parametrize("end, row", [("hub", 0), ("tip", -1)])
def test_make_solid_rejects_a_non_planar_end(end, row):
    s = tapered_tube()
    poles = s.poles.copy()
    poles[:, row, 2] += 3.2 * np.cos(np.linspace(0, 2 * np.pi, len(poles), endpoint=False))
    s = BSplineSurface(poles, s.u_knots, s.u_mults, s.v_knots, s.v_mults, 3, 3, True, False)
    with pytest.raises(BladeReconError, match=rf"the {end} end section is not planar \(max out-of-plane [0-9.]+ mm > 0.01 mm\): export without --solid"):
        make_solid(s)


def test_make_solid_needs_a_closed_section():
    with pytest.raises(BladeReconError, match="periodic in u"):
        make_solid(clamped_surface())


def test_solid_survives_step(tmp_path):
    solid = make_solid(tapered_tube())
    write_step(solid, tmp_path / "solid.step")
    back = read_shape(tmp_path / "solid.step")
    assert len(back.Solids) == 1 and back.isValid()
    assert back.Volume == pytest.approx(solid.Volume, rel=1e-9)


# --------------------------------------------------------------------------- reading
def test_read_shape_other_formats(tmp_path):
    box = Part.makeBox(10, 20, 30)
    box.exportBrep(str(tmp_path / "box.brep"))
    box.exportIges(str(tmp_path / "box.IGS"))
    assert read_shape(tmp_path / "box.brep").Volume == pytest.approx(6000.0)
    assert len(read_shape(tmp_path / "box.IGS").Faces) == 6


def test_read_fcstd_takes_the_visible_part_features(tmp_path):
    doc = FreeCAD.newDocument("ReadShapeTest")
    try:
        doc.addObject("Part::Box", "Shown")
        hidden = doc.addObject("Part::Cylinder", "Hidden")
        hidden.Visibility = False
        lofted = doc.addObject("Part::Feature", "Blade")
        lofted.Shape = make_face(blade_surface())
        lofted.Placement.Base = FreeCAD.Vector(0, 0, 500)
        doc.recompute()
        doc.saveAs(str(tmp_path / "model.FCStd"))
    finally:
        FreeCAD.closeDocument(doc.Name)
    before = set(FreeCAD.listDocuments())
    shape = read_shape(tmp_path / "model.FCStd")
    assert set(FreeCAD.listDocuments()) == before  # the temporary document was closed
    assert len(shape.Faces) == 6 + 1
    assert shape.BoundBox.ZMax > 500  # placements kept


@pytest.mark.parametrize("name, content, message", [
    ("missing.step", None, "file not found"),
    ("empty.step", "", "the file is empty"),
    ("garbage.step", "this is not STEP\n", "cannot read"),
    ("garbage.FCStd", "not a zip\n", "cannot read"),
    ("points.csv", "1,2,3\n", "unknown file type"),
])
def test_read_shape_errors_name_the_file(tmp_path, name, content, message):
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    with pytest.raises(BladeReconError, match=message) as info:
        read_shape(path)
    assert name in str(info.value) and "\n" not in str(info.value)


def test_read_shape_without_faces(tmp_path):
    Part.makeLine((0, 0, 0), (1, 1, 1)).exportBrep(str(tmp_path / "edge.brep"))
    with pytest.raises(BladeReconError, match="holds no faces"):
        read_shape(tmp_path / "edge.brep")


@pytest.mark.parametrize("amplitude, accepted", [(0.008, True), (0.015, False)])
def test_make_solid_default_planar_limit_is_ten_micrometres(amplitude, accepted):
    """The default limit (PLANAR_TOL, 0.01 mm) tells a hub 8 µm out of plane from one 15 µm
    out: a limit ten times looser, or half as tight, fails one of the two. The flatness is
    measured independently of make_solid (end_section_flatness, then checked in range)."""
    s = tapered_tube()
    poles = s.poles.copy()
    poles[:, 0, 2] += amplitude * np.cos(2 * np.linspace(0, 2 * np.pi, len(poles), endpoint=False))
    s = BSplineSurface(poles, s.u_knots, s.u_mults, s.v_knots, s.v_mults, 3, 3, True, False)
    flat = end_section_flatness(s)["hub"]
    if accepted:
        assert 0.005 < flat < 0.0095, flat
        assert make_solid(s).isValid()
    else:
        assert 0.011 < flat < 0.02, flat
        with pytest.raises(BladeReconError, match="hub end section is not planar"):
            make_solid(s)


def test_read_shape_reads_a_file_once_and_each_caller_owns_its_shape(tmp_path, monkeypatch):
    """One command reads its nominal in several steps (plan: four): the second read of an
    unchanged file does not parse it again (OCC's reader counted), gives the same geometry as the
    first (OCC's own area and bounding box), and a caller that moves its shape moves only its
    own. A file rewritten in place (new size and time) is read again, its new content."""
    step = tmp_path / "blade.step"
    write_step(blade_surface(), str(step))
    reads, held = [], export.signals_held

    def counted():                  # read_shape parses a file only inside signals_held()
        reads.append(1)
        return held()
    monkeypatch.setattr(export, "signals_held", counted)
    first = read_shape(str(step))
    area, box = first.Area, first.BoundBox
    first.translate(FreeCAD.Vector(100.0, 0.0, 0.0))
    second = read_shape(str(step))
    assert len(reads) == 1
    assert abs(second.Area - area) < 1e-9 * area and second.BoundBox.isInside(box) and box.isInside(second.BoundBox)
    write_step(tube_surface := clamped_surface(), str(step))
    third = read_shape(str(step))
    assert len(reads) == 2
    assert abs(third.Area - make_face(tube_surface).Area) < 1e-6 * third.Area
