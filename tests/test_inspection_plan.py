# SPDX-License-Identifier: LGPL-2.1-or-later
"""The inspection plan reader (issue 19 §1): the issue's example, and one-line errors naming
the key and the file for unknown keys, wrong types and inverted limits."""
from __future__ import annotations

import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.inspection.plan import read_inspection_plan

EXAMPLE = '''
[profile]                 # ISO 1101 line profile per section: ± half-widths of the zone, mm
leading_edge  = 0.05      # the LE region found by the segmentation
trailing_edge = 0.05
flanks        = 0.08
[parameters]              # [lower, upper] on measured − nominal
chord          = [-0.10, 0.10]
max_thickness  = [-0.05, 0.05]
le_radius      = [-0.03, 0.03]
te_radius      = [-0.03, 0.03]
stagger_deg    = [-0.15, 0.15]
position       = 0.10     # section centroid offset in its plane (radius of a circle)
[fit]
mode        = "rigid"     # none | rigid | translate | rotate-z | zone
per_section = "none"      # none | translate | rotate | both: a 2D best fit of each section for its form
[sections]                # optional: per-section overrides, by index or label
"0" = { flanks = 0.10 }
'''


def _write(tmp_path, text: str):
    p = tmp_path / "plan.toml"
    p.write_text(text, encoding="utf-8")
    return p


def test_the_issue_example_reads(tmp_path):
    plan = read_inspection_plan(_write(tmp_path, EXAMPLE))
    assert plan.profile == {"leading_edge": 0.05, "trailing_edge": 0.05, "flanks": 0.08}
    assert plan.limits["chord"] == (-0.10, 0.10) and plan.limits["stagger_deg"] == (-0.15, 0.15)
    assert plan.position == 0.10 and plan.fit_mode == "rigid" and plan.per_section == "none"
    assert plan.zones_for(0)["flanks"] == 0.10 and plan.zones_for(1)["flanks"] == 0.08


@pytest.mark.parametrize("change, key", [
    (("flanks        = 0.08", "flankz = 0.08"), "profile.flankz"),
    (("[fit]", "[fits]"), "fits"),
    (("chord          = [-0.10, 0.10]", "chord = [0.10, -0.10]"), "parameters.chord"),
    (("chord          = [-0.10, 0.10]", "chord = 0.1"), "parameters.chord"),
    (("chord          = [-0.10, 0.10]", 'chord = ["a", 0.1]'), "parameters.chord"),
    (("flanks        = 0.08", 'flanks = "0.08"'), "profile.flanks"),
    (("flanks        = 0.08", "flanks = -0.08"), "profile.flanks"),
    (("flanks        = 0.08", "flanks = true"), "profile.flanks"),
    (('mode        = "rigid"', 'mode = "minimax"'), "fit.mode"),
    (('per_section = "none"', 'per_section = 1'), "fit.per_section"),
    (('"0" = { flanks = 0.10 }', '"0" = { flank = 0.10 }'), "sections.0.flank"),
    (('"0" = { flanks = 0.10 }', '"0" = 0.10'), "sections.0"),
    (("position       = 0.10", "position = 0"), "parameters.position"),
    (("position       = 0.10", "twist = [-1, 1]"), "parameters.twist"),
])
def test_errors_name_the_key_and_the_file(tmp_path, change, key):
    text = EXAMPLE.replace(*change)
    assert text != EXAMPLE
    path = _write(tmp_path, text)
    with pytest.raises(BladeReconError) as err:
        read_inspection_plan(path)
    msg = str(err.value)
    assert key in msg and str(path) in msg and "\n" not in msg


def test_bad_files(tmp_path):
    with pytest.raises(BladeReconError, match="no such file"):
        read_inspection_plan(tmp_path / "missing.toml")
    with pytest.raises(BladeReconError, match="not valid TOML"):
        read_inspection_plan(_write(tmp_path, "[profile\nflanks = 0.08"))
    with pytest.raises(BladeReconError, match="nothing to check"):
        read_inspection_plan(_write(tmp_path, '[fit]\nmode = "rigid"\n'))
    with pytest.raises(BladeReconError, match="fit.mode"):
        read_inspection_plan(_write(tmp_path, '[fit]\nmode = "zone"\n[parameters]\nchord = [-0.1, 0.1]\n'))


def test_hostile_keys_are_shown_escaped(tmp_path):
    path = _write(tmp_path, '[profile]\n"flanks\\u001b[31m" = 0.08\n')
    with pytest.raises(BladeReconError) as err:
        read_inspection_plan(path)
    assert "\x1b" not in str(err.value) and "profile.flanks" in str(err.value)
