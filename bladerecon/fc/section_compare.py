# SPDX-License-Identifier: LGPL-2.1-or-later
"""Section parameters measured vs nominal, section by section (issue 3 §4 in the issue 4 report).

Every measured section is segmented and measured (:mod:`bladerecon.core.sections.parameters`);
the nominal shape is cut in the plane of that section (:func:`bladerecon.fc.slicing.cut_sections`)
and measured the same way, its LE taken at the end nearest the measured LE. Lengths mm,
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
    """One dict per section: the measured parameters, ``"nominal"`` and ``"difference"``.

    ``flow``: the direction the fluid travels; the LE of the measured and the nominal sections
    is then the upstream end (issue 24), otherwise the measured LE is guessed.

    ``lenient``: an edge with too few points for a radius gives ``None`` and a warning
    instead of an error (a report should not fail over one radius).
    """
    from bladerecon.core.sections.parameters import compare_with_nominal, measure_section, segment_sections
    from bladerecon.core.sections.segmentation import segment_section
    from bladerecon.fc.slicing import cut_sections

    segs = segment_sections(section_points, span_axis, measured_start, flow=flow)
    measured = [measure_section(s, offsets, strict_radius=not lenient) for s in segs]
    origins = np.array([s.frame.origin for s in segs])
    normals = np.array([s.frame.normal for s in segs])
    cuts = cut_sections(name, origins, normals, step, shape=nominal_shape)
    rows = []
    for seg, mp, cut in zip(segs, measured, cuts):
        ns = segment_section(cut, seg.index, span_axis, le_hint=seg.frame.to_space(seg.le)[0], flow=flow)
        rows.append(compare_with_nominal(mp.as_dict(), measure_section(ns, offsets, strict_radius=not lenient).as_dict()))
    return rows
