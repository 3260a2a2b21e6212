# SPDX-License-Identifier: LGPL-2.1-or-later
"""A whole-blade cloud to a surface (issue 25): the one path the command line
(``reconstruct CLOUD``, ``sections CLOUD``) and the workbench (a MeasuredPoints marked as a
cloud, its BladeSurface and BladeSections) both take.

:func:`read_cloud_mm` reads the cloud in mm, :func:`check_cloud_size` refuses one too small to
cut, :func:`cloud_options` checks the user's choices (span axis, span range, number of
sections, rotor axis) and names them as the caller does (``--span-range`` on the command line,
``CloudSpanRange`` in the workbench), :func:`cut_cloud` cuts the sections and chooses the
fitting method (:mod:`bladerecon.core.sections.blade_cloud`), :func:`cloud_surface` skins them
and fits the surface to every node of the cloud, :func:`slicing_lines` says in words what was
chosen and why. Units: mm.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bladerecon.core.errors import BladeReconError

__all__ = ["MIN_CLOUD_POINTS", "CLI_NAMES", "SPAN_AXES", "read_cloud_mm", "check_cloud_size", "cloud_options",
           "CloudCut", "cut_cloud", "cloud_surface", "slicing_lines"]

#: fewest points of a cloud sliced automatically (six sections of a few hundred points)
MIN_CLOUD_POINTS = 2000

#: how the command line names the choices (messages name them as the user gave them)
CLI_NAMES = {"sections": "--sections", "span_axis": "--span-axis", "span_range": "--span-range",
             "rotor_axis": "--rotor-axis", "blade_kind": "--blade-kind", "cloud_scale": "--cloud-scale"}

#: span directions a user may give (hub -> tip)
SPAN_AXES = ("x", "y", "z", "-x", "-y", "-z")


def read_cloud_mm(path: str, scale: float = 1.0, memory_limit: float | None = None,
                  scale_name: str = "--cloud-scale") -> tuple[np.ndarray, np.ndarray]:
    """The cloud of ``path`` (mm, coordinates times ``scale``) and each point's file line: text
    only, file bytes in messages escaped, coordinates within ±1 km. ``scale_name``: how the
    caller names the scale in a message."""
    from bladerecon.core.io.outputs import check_coordinates, shown
    from bladerecon.core.sections import slicing

    try:     # read_points decodes Latin-1 where UTF-8 fails: no UnicodeDecodeError comes out
        P, lines = slicing.read_cloud(path, scale, memory_limit)
    except BladeReconError as err:
        raise BladeReconError(shown(str(err), 400)) from None
    try:
        check_coordinates(P, lines, path)
    except BladeReconError as err:
        scaled = f" (coordinates multiplied by {scale_name} {scale:g})" if scale != 1.0 else ""
        raise BladeReconError(f"{err}{scaled}") from None
    return P, lines


def check_cloud_size(path: str, n: int, other_ways: str = "") -> None:
    """A cloud too small to cut automatically is one line (``other_ways``: what else the caller offers)."""
    if n < MIN_CLOUD_POINTS:
        raise BladeReconError(
            f"{path}: {n} points with no section labels: too few to cut sections from automatically "
            f"(a whole-blade cloud needs at least {MIN_CLOUD_POINTS}); label the sections (a 'section' column, or "
            f"blank lines between blocks){other_ways}")


def _span_range(text: str, name: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(":"))
    except ValueError:
        raise BladeReconError(f"{name} '{text[:40]}': give A:B in mm, e.g. 45:195") from None
    if not (np.isfinite(a) and np.isfinite(b) and a < b):
        raise BladeReconError(f"{name} '{text[:40]}': give A:B with A < B (mm)")
    return a, b


def cloud_options(sections: int | None = None, span_axis: str | None = None, span_range: str | None = None,
                  rotor_axis: str = "z", names: dict | None = None) -> tuple:
    """The user's choices as :func:`cut_cloud` takes them: ``(span axis vector or None, span
    range or None, rotor axis vector)``. None (or "") is "found from the cloud". A count outside
    2..200, a bad span range or axis is one line naming the choice as ``names`` does."""
    names = {**CLI_NAMES, **(names or {})}
    if sections is not None and not 2 <= sections <= 200:
        raise BladeReconError(f"{names['sections']} {sections}: give 2 to 200")
    axis = None
    if span_axis:
        if span_axis not in SPAN_AXES:
            raise BladeReconError(f"{names['span_axis']} '{span_axis[:20]}': give one of {', '.join(SPAN_AXES)}")
        axis = np.eye(3)["xyz".index(span_axis[-1])] * (-1.0 if span_axis.startswith("-") else 1.0)
    rng = _span_range(span_range, names["span_range"]) if span_range else None
    if rotor_axis not in ("x", "y", "z"):
        raise BladeReconError(f"{names['rotor_axis']} '{str(rotor_axis)[:20]}': give x, y or z")
    return axis, rng, np.eye(3)["xyz".index(rotor_axis)]


@dataclass
class CloudCut:
    """The sections cut from a cloud and what was chosen: ``cloud`` the
    :class:`~bladerecon.core.sections.cloud.CloudSections` (with the whole cloud, for the fit),
    ``sections`` the ordered :class:`~bladerecon.core.sections.ordering.SectionSet`, ``info``
    the ``slicing`` record of ``reconstruct --json`` (kind, axis, span, sections, slab, and the
    method and its reason when it was chosen here), ``method`` the fitting method."""

    cloud: object = field(repr=False)
    sections: object = field(repr=False)
    lines: np.ndarray = field(repr=False)
    source: str
    info: dict = field(repr=False)
    method: str

    def pointset(self):
        """The section points as a :class:`~bladerecon.core.io.readers.PointSet` (the file's lines)."""
        return self.cloud.pointset(self.lines, self.source)


def cut_cloud(P: np.ndarray, lines: np.ndarray, source: str, kind: str = "auto", span_range=None,
              n_sections: int | None = None, span_axis=None, rotor_axis=(0.0, 0.0, 1.0), method: str | None = "auto",
              scale: float = 1.0) -> CloudCut:
    """Cut the cloud ``P`` (mm; ``lines`` its file lines, ``source`` its name) into sections
    (:func:`~bladerecon.core.sections.blade_cloud.cut_sections`: planes, or stream surfaces for a
    radial rotor) and, with ``method`` 'auto', choose interpolation or smoothing on the cloud's
    own nodes (:func:`~bladerecon.core.sections.blade_cloud.choose_method`); ``method`` None:
    sections only (nothing is fitted). ``scale``: the unit factor the cloud was read with (recorded)."""
    from bladerecon.core.sections.blade_cloud import choose_method, cut_sections, section_set

    cs = cut_sections(P, kind, span_range, n_sections, span_axis, rotor_axis)
    info = dict(cs.info)
    info["cloud_scale"] = scale
    ss = section_set(cs, lines, source)
    if method == "auto":
        method, info["method_reason"], info["method_scores"] = choose_method(cs, P, ss)
    return CloudCut(cs, ss, np.asarray(lines), source, info, method)


def cloud_surface(cut: CloudCut, pts: list, span_axis, tolerance: float | None = None,
                  first_point_is_measured: bool = True, offset: float = 0.0, say=None):
    """The surface through the sections ``pts`` (the points of ``cut.sections``, moved as the
    caller needs: probe compensation, upstream start) with ``cut.method``, fitted to every node
    of the cloud (:func:`~bladerecon.core.sections.blade_cloud.fit_to_cloud`; ``offset`` the
    probe radius + coating the sections were moved by). Returns ``(reconstruction, cloud fit
    info, distances of the fitted nodes (mm) or None when the sections' surface was kept)``:
    the surface is judged by those nodes, not by the section points slid onto their planes."""
    from bladerecon.core.reconstruct import reconstruct
    from bladerecon.core.sections.blade_cloud import fit_to_cloud

    rec = reconstruct(pts, span_axis, method=cut.method, tolerance=tolerance,
                      first_point_is_measured=first_point_is_measured)
    if say is not None:
        say("fitting the surface to the whole cloud")
    return fit_to_cloud(rec, cut.cloud, offset=offset)


def _mm(v) -> str:
    return f"{float(v):.2f}"


def slicing_lines(info: dict, cloud_fit: dict | None = None) -> list[str]:
    """What was chosen for a cloud and why, a line each (span axis, span, kind, sections, slab,
    method, fit to the cloud): the workbench's ``Slicing``; ``info`` a :class:`CloudCut`'s."""
    out = []
    radial = info.get("kind") == "stream-surfaces"
    axis = info.get("axis")
    if axis is not None:
        a = np.asarray(axis, float)
        k = int(np.argmax(np.abs(a)))
        name = (("-" if a[k] < 0 else "") + "xyz"[k] if abs(abs(a[k]) - 1.0) < 1e-9
                else "(" + ", ".join(f"{v:.4f}" for v in a) + ")")
        what = "rotor axis" if radial else "span axis"
        out.append(f"{what}: {name}" + (f" ({info['axis_reason']})" if info.get("axis_reason") else ""))
    if radial:
        fr = info.get("span_fractions") or []
        if fr:
            out.append(f"span: fractions {fr[0]:.3f} to {fr[-1]:.3f} between hub and shroud"
                       f" (channel {_mm(info.get('unrolled_height_mm', 0.0))} mm high)")
    elif info.get("airfoil_span_mm"):
        lo, hi = info["airfoil_span_mm"]
        why = info.get("span_reason") or {}
        reason = why.get("method", "") if isinstance(why, dict) else str(why)
        left = info.get("points_left_out") or {}
        out.append(f"span: {_mm(lo)} to {_mm(hi)} mm along the span axis ({reason}"
                   + (f"; {left.get('below', 0)} points below and {left.get('above', 0)} above left out" if left else "")
                   + ")")
    out.append(f"kind: {info.get('kind', '?')}" + (f" ({info['kind_reason']})" if info.get("kind_reason") else ""))
    out.append(f"sections: {info.get('sections', '?')}"
               + (f" ({info['sections_reason']})" if info.get("sections_reason") else ""))
    if info.get("slab_mm") is not None:
        out.append(f"slab width: {_mm(info['slab_mm'])} mm")
    elif info.get("shell_span_fraction") is not None:
        out.append(f"slab width: {info['shell_span_fraction']:.4f} of the span")
    if info.get("method_reason"):
        out.append(f"method: {info['method_reason']}")
    if cloud_fit:
        out.append(f"fit to the cloud: {cloud_fit.get('reason', '')}")
    out.append(f"cloud: {info.get('cloud_points', '?')} points, coordinates times {info.get('cloud_scale', 1.0):g}")
    return out
