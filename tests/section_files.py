# SPDX-License-Identifier: LGPL-2.1-or-later
"""Writing section files the way the tests need them: ``section,x,y,z``, every coordinate as
its shortest round-trip text (plain Python floats: numpy 2's repr would write ``np.float64(..)``)."""
from __future__ import annotations

from pathlib import Path


def write_sections_csv(path: Path, sections) -> Path:
    """Sections (a list of (n, 3) arrays) as a labelled ``section,x,y,z`` file, labels 0, 1, ..."""
    Path(path).write_text("section,x,y,z\n" + "".join(f"{k},{float(x)!r},{float(y)!r},{float(z)!r}\n"
                                                      for k, p in enumerate(sections) for x, y, z in p))
    return Path(path)
