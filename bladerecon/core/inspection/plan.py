# SPDX-License-Identifier: LGPL-2.1-or-later
"""The inspection plan: profile zones, parameter limits and best-fit modes, read from TOML.

Issue 19 §1. Lengths in mm, angles in degrees. The file (read with Python's own ``tomllib``)::

    [profile]                 # ISO 1101 line profile per section: ± half-widths of the zone, mm
    leading_edge  = 0.05
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
    per_section = "none"      # none | translate | rotate | both
    [sections]                # optional per-section overrides, by index or label
    "0" = { flanks = 0.10 }

Every table and key is optional except that a plan must say something to check ([profile]
or [parameters]). Unknown keys, wrong types, non-positive zones and inverted limits raise
:class:`BladeReconError` naming the key and the file.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import shown

__all__ = ["InspectionPlan", "ZONES", "PARAMETERS", "FIT_MODES", "PER_SECTION_MODES",
           "read_inspection_plan", "parse_inspection_plan"]

#: profile zones, in the order the verdicts list them
ZONES = ("leading_edge", "trailing_edge", "flanks")
#: parameters with [lower, upper] limits on measured − nominal (mm or degrees)
PARAMETERS = ("chord", "max_thickness", "le_radius", "te_radius", "stagger_deg")
FIT_MODES = ("none", "rigid", "translate", "rotate-z", "zone")
PER_SECTION_MODES = ("none", "translate", "rotate", "both")


@dataclass(frozen=True)
class InspectionPlan:
    """A parsed inspection plan (mm, degrees).

    ``profile``: zone name -> half-width (mm), only the zones the plan gives; ``limits``:
    parameter -> (lower, upper); ``position``: the largest centroid offset (mm) or None;
    ``overrides``: section key (index as text, or label) -> {zone: half-width}.
    """

    source: str
    profile: dict = field(default_factory=dict)
    limits: dict = field(default_factory=dict)
    position: float | None = None
    fit_mode: str = "rigid"
    per_section: str = "none"
    overrides: dict = field(default_factory=dict)

    def zones_for(self, index: int, label: str | None = None) -> dict:
        """The profile half-widths (mm) of section ``index`` (label ``label``), overrides applied.

        An override by label wins over one by index."""
        out = dict(self.profile)
        out.update(self.overrides.get(str(index), {}))
        if label is not None and str(label) != str(index):
            out.update(self.overrides.get(str(label), {}))
        return out

    def as_dict(self) -> dict:
        return {"source": self.source, "profile": dict(self.profile),
                "parameters": {k: list(v) for k, v in self.limits.items()}, "position": self.position,
                "fit": {"mode": self.fit_mode, "per_section": self.per_section},
                "sections": {k: dict(v) for k, v in self.overrides.items()}}


def read_inspection_plan(path: str | os.PathLike) -> InspectionPlan:
    """Read and check an inspection plan TOML file (see the module docstring)."""
    import tomllib

    name = shown(os.fspath(path), limit=1000)
    try:
        path = os.fspath(path)
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise BladeReconError(f"inspection plan {name}: no such file") from None
    except IsADirectoryError:
        raise BladeReconError(f"inspection plan {name}: is a folder, give the .toml file") from None
    except OSError as err:
        raise BladeReconError(f"inspection plan {name}: cannot read it ({err.strerror})") from None
    except UnicodeDecodeError:
        raise BladeReconError(f"inspection plan {name}: not UTF-8 text (a TOML file is)") from None
    except tomllib.TOMLDecodeError as err:
        raise BladeReconError(f"inspection plan {name}: not valid TOML: {err}") from None
    return parse_inspection_plan(data, name)


def _number(value, key: str, src: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BladeReconError(f"inspection plan {src}: {key} = {value!r}: give a number (mm or degrees)")
    v = float(value)
    if v != v or v in (float("inf"), float("-inf")):
        raise BladeReconError(f"inspection plan {src}: {key} = {value!r}: give a finite number")
    return v


def _half_width(value, key: str, src: str) -> float:
    v = _number(value, key, src)
    if not v > 0:
        raise BladeReconError(f"inspection plan {src}: {key} = {value!r}: a zone half-width must be > 0 mm")
    return v


def _table(data: dict, key: str, src: str) -> dict:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise BladeReconError(f"inspection plan {src}: [{key}] must be a table, got {value!r}")
    return value


def _unknown(table: dict, allowed, where: str, src: str) -> None:
    for k in table:
        if k not in allowed:
            raise BladeReconError(f"inspection plan {src}: unknown key {where}{shown(k)}: use one of "
                                  f"{', '.join(allowed)}")


def _limits(value, key: str, src: str) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise BladeReconError(f"inspection plan {src}: {key} = {value!r}: give [lower, upper] "
                              "on measured − nominal")
    lo, hi = (_number(v, key, src) for v in value)
    if lo > hi:
        raise BladeReconError(f"inspection plan {src}: {key} = [{lo:g}, {hi:g}]: lower limit above "
                              "the upper one: swap them")
    return lo, hi


def parse_inspection_plan(data: dict, source: str = "plan") -> InspectionPlan:
    """Check a plan given as the dict ``tomllib`` returns; ``source`` names it in messages."""
    src = shown(source, limit=1000)
    _unknown(data, ("profile", "parameters", "fit", "sections"), "", src)
    profile_t = _table(data, "profile", src)
    _unknown(profile_t, ZONES, "profile.", src)
    profile = {k: _half_width(profile_t[k], f"profile.{k}", src) for k in ZONES if k in profile_t}

    params_t = _table(data, "parameters", src)
    _unknown(params_t, (*PARAMETERS, "position"), "parameters.", src)
    limits = {k: _limits(params_t[k], f"parameters.{k}", src) for k in PARAMETERS if k in params_t}
    position = None
    if "position" in params_t:
        position = _half_width(params_t["position"], "parameters.position", src)

    fit_t = _table(data, "fit", src)
    _unknown(fit_t, ("mode", "per_section"), "fit.", src)
    mode = fit_t.get("mode", "rigid")
    if mode not in FIT_MODES:
        raise BladeReconError(f"inspection plan {src}: fit.mode = {mode!r}: use one of {', '.join(FIT_MODES)}")
    per_section = fit_t.get("per_section", "none")
    if per_section not in PER_SECTION_MODES:
        raise BladeReconError(f"inspection plan {src}: fit.per_section = {per_section!r}: use one of "
                              f"{', '.join(PER_SECTION_MODES)}")

    overrides = {}
    for raw_key, table in _table(data, "sections", src).items():
        key = shown(raw_key)
        if not isinstance(table, dict):
            raise BladeReconError(f"inspection plan {src}: sections.{key} = {table!r}: give a table of zone "
                                  f"half-widths, e.g. {{ flanks = 0.10 }}")
        _unknown(table, ZONES, f"sections.{key}.", src)
        overrides[str(raw_key)] = {z: _half_width(v, f"sections.{key}.{z}", src) for z, v in table.items()}
    if mode == "zone" and not profile and not overrides:
        raise BladeReconError(f"inspection plan {src}: fit.mode = \"zone\" fits the points into their profile "
                              "zones: give [profile] half-widths")
    if not profile and not limits and position is None and not overrides:
        raise BladeReconError(f"inspection plan {src}: nothing to check: give [profile] zones or "
                              "[parameters] limits")
    return InspectionPlan(src, profile, limits, position, mode, per_section, overrides)
