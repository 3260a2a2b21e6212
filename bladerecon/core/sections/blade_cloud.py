# SPDX-License-Identifier: LGPL-2.1-or-later
"""Which sections to cut from a whole-blade cloud: planes across the span (axial blades,
propellers, fans) or stream surfaces between hub and shroud (radial and mixed-flow rotors).

Planes are tried first (:func:`bladerecon.core.sections.cloud.auto_sections`); when their cuts
are open curves — the largest step along an ordered cut more than ``OPEN_GAP_RATIO`` x its
median point spacing, on the median section — or the planar cut fails, the blade is taken as
radial and cut on stream surfaces about the rotor axis
(:func:`bladerecon.core.sections.meridional.meridional_sections`). Units: mm.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.sections.cloud import CloudSections, auto_sections
from bladerecon.core.sections.meridional import meridional_sections

__all__ = ["cut_sections", "section_set", "choose_method", "OPEN_GAP_RATIO", "HELD_OUT"]

#: cloud nodes between the sections (not in them) that judge the fitting method
HELD_OUT = 3000

#: a planar cut whose loop jumps by more than this x its median point spacing is an open curve
#: (airfoils of the test blades: at most 16x; planes through the radial test rotor: 15-60x)
OPEN_GAP_RATIO = 20.0


def cut_sections(P: np.ndarray, kind: str = "auto", span_range=None, n_sections: int | None = None,
                 span_axis=None, rotor_axis=(0.0, 0.0, 1.0)) -> CloudSections:
    """Sections of the cloud ``P`` (mm); ``kind`` 'auto', 'axial' or 'radial'. The chosen kind and
    why are in ``info['kind_reason']``. ``span_range``: mm along the span axis (axial) or span
    fractions hub 0 .. shroud 1 (radial)."""
    if kind not in ("auto", "axial", "radial"):
        raise BladeReconError(f"blade kind '{kind}': use auto, axial or radial")
    rotor_name = "xyz"[int(np.argmax(np.abs(rotor_axis)))]
    if kind == "radial":
        cs = meridional_sections(P, rotor_axis, n_sections, span_range)
        cs.info["kind_reason"] = "radial requested"
        return cs
    try:
        cs, planar_error = auto_sections(P, span_range=span_range, n_sections=n_sections, axis=span_axis), None
    except BladeReconError as err:
        if kind == "axial":
            raise
        cs, planar_error = None, str(err)
    if kind == "axial":
        cs.info["kind_reason"] = "axial requested"
        return cs
    gap = float(np.median(cs.info["largest_gap_ratio"])) if cs is not None else np.inf
    if gap <= OPEN_GAP_RATIO:
        cs.info["kind_reason"] = (f"axial: planes across the span cut closed airfoils (largest gap along a "
                                  f"section {gap:.0f}x the median spacing, at most {OPEN_GAP_RATIO:g})")
        return cs
    why = (f"planes across the span failed ({planar_error})" if cs is None else
           f"planes cut it into open curves (largest gap along a section {gap:.0f}x the median spacing, "
           f"over {OPEN_GAP_RATIO:g})")
    cs = meridional_sections(P, rotor_axis, n_sections, span_range)
    cs.info["kind_reason"] = f"radial: {why}; stream surfaces about {rotor_name} between hub and shroud"
    return cs


def section_set(cs: CloudSections, lines: np.ndarray, source: str):
    """The ordered sections of ``cs`` for the surface fit: stream-surface sections as cut,
    planar ones through ``build_sections`` (which keeps their geometric order)."""
    from bladerecon.core.sections.ordering import build_sections

    if cs.info.get("kind") == "stream-surfaces":
        return cs.section_set(lines, source)
    return build_sections(cs.pointset(lines, source))


def choose_method(cs: CloudSections, P: np.ndarray, sections) -> tuple[str, str, dict]:
    """``interpolate`` or ``approximate`` for the sections of a cloud, judged on the cloud's own
    nodes that lie between the sections but in none of them (up to ``HELD_OUT``, evenly
    picked): the method whose surface they are closer to (RMS) wins. Returns
    ``(method, reason, {method: {rms_mm, max_mm}})``."""
    from bladerecon.core.geometry.projection import project_points_to_surface
    from bladerecon.core.reconstruct import reconstruct

    used = np.zeros(len(P), dtype=bool)
    used[np.concatenate(cs.rows)] = True
    held = np.setdiff1d(cs.between if cs.between is not None else np.arange(len(P)), np.flatnonzero(used))
    if held.size < 50:
        return "interpolate", "interpolate: fewer than 50 nodes between the sections to judge by", {}
    held = held[np.linspace(0, held.size - 1, min(HELD_OUT, held.size)).round().astype(int)]
    pts = [s.points for s in sections.sections]
    scores = {}
    for method in ("interpolate", "approximate"):
        try:
            rec = reconstruct(pts, sections.span_axis, method=method)
        except BladeReconError:
            continue
        d = project_points_to_surface(rec.surface, P[held]).distance
        scores[method] = {"rms_mm": float(np.sqrt(np.mean(d * d))), "max_mm": float(d.max())}
    if not scores:
        return "interpolate", "interpolate: neither fit could be judged", {}
    best = min(scores, key=lambda m: scores[m]["rms_mm"])
    text = ", ".join(f"{m} {v['rms_mm'] * 1000:.1f} µm" for m, v in scores.items())
    return best, (f"{best}: closer to the {held.size} cloud nodes between the sections (RMS: {text})"), scores
