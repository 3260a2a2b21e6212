# SPDX-License-Identifier: LGPL-2.1-or-later
"""``tools/make_sample_data.py`` writes the shipped sample and example files byte for byte.

It is run into a temporary folder and every file it writes is compared with the one in
``resources/sample/`` and ``resources/examples/``, which must hold nothing else.

``nominal.step`` is compared byte for byte, and where the bytes differ the two files are read
back and their B-spline surfaces compared (poles, knots, multiplicities, degrees, periodicity;
to 1e-9 mm): another OpenCASCADE writes another header (it names the writer's version, e.g.
``Open CASCADE STEP processor 7.6``) and may number and format the entities differently, and
on another CPU the same one may print a pole's 15th digit differently (numpy's BLAS kernel,
chosen per CPU, rounds its sums differently).
"""
from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TOOL = ROOT / "tools" / "make_sample_data.py"
SAMPLE = ROOT / "resources" / "sample"
EXAMPLES = ROOT / "resources" / "examples"
_WRITER = re.compile(rb"'(Open CASCADE STEP processor [^']*)'")


def _freecad():
    from bladerecon.fc.freecad_env import import_freecad

    import_freecad()     # FreeCAD is a dependency (make deps): missing or broken fails, never skips
    import FreeCAD

    return FreeCAD


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory):
    out = tmp_path_factory.mktemp("regenerated")
    args = [sys.executable, str(TOOL), "--out", str(out / "sample"), "--examples-out", str(out / "examples")]
    run = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    return out


@pytest.mark.timeout(900)
@pytest.mark.parametrize("shipped", [SAMPLE, EXAMPLES], ids=["sample", "examples"])
def test_text_files_are_reproduced_byte_for_byte(regenerated, shipped):
    made = regenerated / shipped.name
    names = sorted(p.name for p in made.iterdir())
    expected = sorted(p.name for p in shipped.iterdir() if p.name != "nominal.step")
    assert sorted(n for n in names if n != "nominal.step") == expected, "the tool writes other files than are shipped"
    differ = [n for n in expected if (made / n).read_bytes() != (shipped / n).read_bytes()]
    assert not differ, f"regenerated files differ from the shipped ones: {differ}"


@pytest.mark.timeout(900)
def test_nominal_step_is_reproduced(regenerated):
    _freecad()
    made = (regenerated / "sample" / "nominal.step").read_bytes()
    shipped = (SAMPLE / "nominal.step").read_bytes()
    writer_made, writer_shipped = _WRITER.search(made).group(1), _WRITER.search(shipped).group(1)
    if made == shipped:
        return
    # Not byte for byte: another OCC writer, or the same one fed poles that differ in the last of
    # their 15 printed digits. The BLAS kernel numpy uses is chosen per CPU (OpenBLAS: Haswell,
    # SkylakeX, Zen, ...), and its sums round differently: an AMD EPYC machine with the same
    # packages wrote 15.902711298796 where the shipped file (made on another CPU) has ...797.
    # The surface is then compared as geometry: the same knots and poles to 1e-9 mm.
    import Part

    def surface(data: bytes, name: str):
        path = regenerated / name
        path.write_bytes(data)
        shape = Part.read(str(path))
        assert len(shape.Faces) == 1
        return shape.Faces[0].Surface

    a, b = surface(made, "made.step"), surface(shipped, "shipped.step")
    assert (a.UDegree, a.VDegree, a.isUPeriodic(), a.isVPeriodic()) == \
           (b.UDegree, b.VDegree, b.isUPeriodic(), b.isVPeriodic())
    assert (a.getUMultiplicities(), a.getVMultiplicities()) == (b.getUMultiplicities(), b.getVMultiplicities())
    assert max(abs(x - y) for x, y in zip(a.getUKnots() + a.getVKnots(), b.getUKnots() + b.getVKnots())) < 1e-12
    pa, pb = a.getPoles(), b.getPoles()
    assert (len(pa), len(pa[0])) == (len(pb), len(pb[0]))
    worst = max((p - q).Length for ra, rb in zip(pa, pb) for p, q in zip(ra, rb))
    print(f"\nnominal.step written by {writer_made}, shipped by {writer_shipped}: poles agree to {worst:.1e} mm")
    assert worst < 1e-9


def test_step_time_stamp_is_replaced(tmp_path):
    """The one variable part of OpenCASCADE's STEP output, the FILE_NAME time, is fixed."""
    spec = importlib.util.spec_from_file_location("make_sample_data", TOOL)
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    path = tmp_path / "x.step"
    header = ("ISO-10303-21;\nHEADER;\nFILE_NAME('Open CASCADE Shape Model','{}',('FreeCAD'),(\n"
              "    'FreeCAD'),'Open CASCADE STEP processor 7.6','FreeCAD','Unknown');\nENDSEC;\n")
    path.write_text(header.format("2031-05-06T07:08:09"))
    tool.normalise_step_header(path)
    assert path.read_text() == header.format(tool.STEP_TIMESTAMP)
    assert f"'{tool.STEP_TIMESTAMP}'".encode() in (SAMPLE / "nominal.step").read_bytes()
