# SPDX-License-Identifier: LGPL-2.1-or-later
"""Section parameters measured vs nominal, section by section (issue 3 §4 in the issue 4 report).

Every measured section is segmented and measured (:mod:`bladerecon.core.sections.parameters`);
the nominal shape is cut in the plane of that section (:func:`bladerecon.fc.slicing.cut_sections`)
and measured the same way; the LE from the flow direction or else from the nominal. Lengths mm,
angles degrees; differences are measured − nominal.
"""
from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["compare_section_parameters"]


def compare_section_parameters(section_points: list[np.ndarray], span_axis: np.ndarray, measured_start: bool,
                               nominal_shape: Any, offsets: tuple[float, ...] = (), step: float = 0.05,
                               lenient: bool = True, name: str = "nominal", flow: np.ndarray | None = None
                               ) -> list[dict]:
    """One dict per section: the measured parameters, ``"nominal"``, ``"difference"`` and
    ``"le_rule"``.

    ``flow``: the direction the fluid travels; the LE of the measured and the nominal sections
    is then the upstream end (issue 24). Without it the nominal decides (``"le_rule":
    "nominal"``): its LE is its blunter end on most sections, judged on the exact CAD
    geometry, and every measured LE is the end nearest the nominal's LE in that section, so a
    worn or damaged measured edge cannot swap them.

    ``lenient``: an edge with too few points for a radius gives ``None`` and a warning
    instead of an error (a report should not fail over one radius).
    """
    from bladerecon.core.sections.parameters import compare_with_nominal, measure_section, segment_blade
    from bladerecon.core.sections.segmentation import section_frame, segment_section
    from bladerecon.fc.slicing import cut_sections

    frames = [section_frame(np.asarray(p, float), span_axis) for p in section_points]
    origins = np.array([f.origin for f in frames])
    normals = np.array([f.normal for f in frames])
    cuts = cut_sections(name, origins, normals, step, shape=nominal_shape)
    if flow is None:
        nsegs = segment_blade(cuts, span_axis, canonical=True).sections
        blade = segment_blade(section_points, span_axis, measured_start, canonical=True,
                              le_points=[s.frame.to_space(s.le)[0] for s in nsegs])
        segs = blade.sections
    else:
        blade = segment_blade(section_points, span_axis, measured_start, flow=flow, canonical=True)
        segs = blade.sections
        nsegs = [segment_section(cut, seg.index, span_axis, le_hint=seg.frame.to_space(seg.le)[0], flow=flow)
                 for seg, cut in zip(segs, cuts)]
    rows = []
    for seg, ns in zip(segs, nsegs):
        row = compare_with_nominal(measure_section(seg, offsets, strict_radius=not lenient).as_dict(),
                                   measure_section(ns, offsets, strict_radius=not lenient).as_dict())
        row["le_rule"] = blade.le_rule
        rows.append(row)
    return rows
