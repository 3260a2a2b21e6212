# SPDX-License-Identifier: LGPL-2.1-or-later
"""bladerecon.fc.freecad_env: FreeCAD is found without help, quietly, or a one-line hint is given."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from fc_fixtures import require_freecad

require_freecad()

REPO = Path(__file__).resolve().parents[1]


def _run(code: str, **env: str) -> subprocess.CompletedProcess:
    base = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(REPO), "HOME": str(Path.home())}
    return subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120, env={**base, **env})


def test_import_freecad_finds_it_in_a_plain_interpreter_and_prints_nothing():
    code = (
        "import sys\n"
        "assert 'FreeCAD' not in sys.modules\n"
        "from bladerecon.fc.freecad_env import import_freecad\n"
        "FreeCAD, Part = import_freecad()\n"
        "box = Part.makeBox(1, 2, 3)\n"
        "from bladerecon.fc.export import write_step, read_shape\n"
        "import tempfile, os\n"
        "d = tempfile.mkdtemp()\n"
        "write_step(box, os.path.join(d, 'b.step'))\n"
        "assert abs(read_shape(os.path.join(d, 'b.step')).Volume - 6) < 1e-9\n"
        "sys.stderr.write('FOUND ' + FreeCAD.__file__)\n"
    )
    proc = _run(code)
    assert proc.returncode == 0, proc.stderr
    assert "FOUND" in proc.stderr
    assert proc.stdout == ""  # stdout is kept for --json


def test_freecad_lib_override_is_tried_first():
    from bladerecon.fc.freecad_env import candidate_lib_dirs, find_freecad_lib

    lib = Path(find_freecad_lib())
    proc = _run(
        "from bladerecon.fc.freecad_env import candidate_lib_dirs, import_freecad\n"
        "print(candidate_lib_dirs()[0]); import_freecad()",
        FREECAD_LIB=str(lib),
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == str(lib)
    assert "/usr/lib/freecad/lib" in candidate_lib_dirs() or sys.platform != "linux"


def test_not_found_is_one_line_with_the_install_hint():
    code = (
        "import bladerecon.fc.freecad_env as env\n"
        "env.candidate_lib_dirs = lambda: ['/nonexistent/freecad/lib']\n"
        "from bladerecon.core.errors import BladeReconError\n"
        "try:\n"
        "    env.import_freecad()\n"
        "except BladeReconError as err:\n"
        "    print(err)\n"
    )
    proc = _run(code, FREECAD_LIB="/nonexistent/freecad/lib")
    assert proc.returncode == 0, proc.stderr
    message = proc.stdout.strip()
    assert "\n" not in message
    assert "apt-get install freecad" in message and "FREECAD_LIB" in message
