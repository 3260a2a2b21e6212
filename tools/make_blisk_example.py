# SPDX-License-Identifier: LGPL-2.1-or-later
"""Write ``resources/blisk/``: the small synthetic blisk the ``blisk`` examples of docs/batch.md use.

Run from the repository root: ``/usr/bin/python3 tools/make_blisk_example.py`` (needs FreeCAD
for the STEP). Fixed seed: the same files every run (the STEP's time stamp is normalised).
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

OUT = ROOT / "resources" / "blisk"
N_BLADES, N_SECTIONS, N_POINTS, SEED = 12, 4, 50, 3
PITCH_ERRORS = {5: 0.2}
README = """# A synthetic blisk (example input of `blisk` in docs/batch.md)

Written by `tools/make_blisk_example.py` (fixed seed; do not edit by hand). Coordinates in mm.

| file | what |
|---|---|
| `points.csv` | `section,x,y,z`: {n} blades of the sample blade about the z axis (blade 0's hub at x = {hub:g} mm, its span along +x), {s} sections x {p} points per blade (section `k*{s}+j` is blade k's section j), each blade offset along its normal by N(0, 3 µm), 2 µm noise; blade 5 is 0.2° out of pitch (`samples.blisk.blisk_scan({n}, n_sections={s}, n_points={p}, pitch_errors={{5: 0.2}}, seed={seed})`) |
| `blade0.step` | blade 0's nominal in the blisk's frame: the sample nominal surface (11 x 400 interpolated points, coarser than resources/sample/nominal.step to keep the file small) placed by `samples.blisk.placement()` |
"""


def main() -> None:
    from bladerecon.core.io.readers import write_points_csv
    from bladerecon.samples.blisk import HUB_RADIUS, blisk_nominal_surface, blisk_scan

    OUT.mkdir(parents=True, exist_ok=True)
    scan = blisk_scan(N_BLADES, n_sections=N_SECTIONS, n_points=N_POINTS, pitch_errors=PITCH_ERRORS, seed=SEED)
    write_points_csv(OUT / "points.csv", scan.points.round(6), scan.section)
    from bladerecon.fc.freecad_env import import_freecad

    import_freecad()
    from bladerecon.fc.convert import make_face
    from bladerecon.fc.export import write_step
    from make_sample_data import normalise_step_header

    write_step(make_face(blisk_nominal_surface(n_span=11, n_profile=400)), str(OUT / "blade0.step"))
    normalise_step_header(OUT / "blade0.step")
    (OUT / "README.md").write_text(README.format(n=N_BLADES, hub=HUB_RADIUS, s=N_SECTIONS, p=N_POINTS, seed=SEED))
    print(f"wrote {OUT}: points.csv ({len(scan.points)} points), blade0.step, README.md")


if __name__ == "__main__":
    main()
