# SPDX-License-Identifier: LGPL-2.1-or-later
"""Statistics of a production lot: per feature the mean, standard deviation, min/max, the
worst blades and the process capability Cp/Cpk against limits (mm, degrees, %).

A blade's *record* is a plain dict (``bladerecon batch`` builds it from the blade's
``deviation --json`` summary): ``{"blade", "status", "stats": {...}, "sections": [...],
"position": {...}}``. :func:`feature_values` flattens it into ``feature -> value``; the
feature names are ``deviation.<stat>``, ``section.<index>.<parameter>`` (measured minus
nominal) and ``position.<error>``. Everything here is a function of the records in their
given order, so the same lot gives the same numbers, bit for bit.

Capability (Montgomery, *Introduction to Statistical Quality Control*, ch. 8)::

    Cp  = (USL - LSL) / (6 s)
    Cpk = min(USL - mean, mean - LSL) / (3 s)        (one-sided: the side given)

with ``s`` the sample standard deviation (ddof = 1).
"""
from __future__ import annotations

import numpy as np

__all__ = ["DEVIATION_FEATURES", "feature_values", "capability", "lot_statistics", "tolerance_limits"]

# The deviation statistics a lot follows (mm, and % within the tolerance).
DEVIATION_FEATURES = ("max", "min", "mean", "std", "rms", "max_abs", "mean_abs", "within_tolerance_pct")
_WORST = 3            # worst blades listed per feature


def feature_values(record: dict) -> dict[str, float]:
    """``feature -> value`` of one blade's record (empty for a failed blade)."""
    if record.get("status") != "ok":
        return {}
    out: dict[str, float] = {}
    stats = record.get("stats") or {}
    for name in DEVIATION_FEATURES:
        if name in stats and stats[name] is not None:
            out[f"deviation.{name}"] = float(stats[name])
    for row in record.get("sections") or ():
        for name, value in sorted((row.get("difference") or {}).items()):
            if isinstance(value, (int, float)) and value is not None:
                out[f"section.{row['index']}.{name}"] = float(value)
    for name, value in sorted((record.get("position") or {}).items()):
        if isinstance(value, (int, float)):
            out[f"position.{name}"] = float(value)
    return out


def tolerance_limits(tolerance: float) -> dict[str, tuple[float | None, float | None]]:
    """Limits the profile tolerance ±``tolerance`` mm puts on the deviation statistics."""
    t = float(tolerance)
    return {"deviation.max": (None, t), "deviation.min": (-t, None), "deviation.max_abs": (None, t),
            "deviation.mean": (-t, t)}


def capability(values, lsl: float | None, usl: float | None) -> dict:
    """Cp and Cpk of ``values`` against the limits (either may be None: one-sided).

    None where it is undefined: fewer than 2 values, no spread, or (Cp) a one-sided limit.
    """
    x = np.asarray(values, float)
    out: dict = {"lsl": lsl, "usl": usl, "cp": None, "cpk": None}
    if x.size < 2 or (lsl is None and usl is None):
        return out
    s = float(np.std(x, ddof=1))
    if not s > 0:
        return out
    mean = float(np.mean(x))
    if lsl is not None and usl is not None:
        out["cp"] = (usl - lsl) / (6.0 * s)
    sides = [v for v in ((usl - mean) if usl is not None else None,
                         (mean - lsl) if lsl is not None else None) if v is not None]
    out["cpk"] = min(sides) / (3.0 * s)
    return out


def _worst(names: list[str], x: np.ndarray, lsl, usl) -> list[dict]:
    """The blades farthest from the middle of the limits (or from the lot mean), worst first;
    ties keep the lot order (a stable sort), so the list is reproducible."""
    if lsl is not None and usl is not None:
        score = np.abs(x - 0.5 * (lsl + usl))
    elif usl is not None:               # only an upper limit: the largest values are the worst
        score = x
    elif lsl is not None:
        score = -x
    else:
        score = np.abs(x - float(np.mean(x)))
    order = np.argsort(-score, kind="stable")[:_WORST]
    return [{"blade": names[i], "value": float(x[i])} for i in order]


def lot_statistics(records: list[dict], limits: dict | None = None) -> dict:
    """Per feature: ``n``, ``mean``, ``std`` (sample, ddof 1; None for one blade), ``min``,
    ``max``, ``worst`` blades and, where ``limits`` gives ``(lsl, usl)``, ``cp``/``cpk``.

    Features appear in a fixed order: deviation statistics, then sections, then positions,
    each sorted by name (sections by index).
    """
    limits = limits or {}
    per_blade = [(r["blade"], feature_values(r)) for r in records]
    names = sorted({f for _, v in per_blade for f in v}, key=_feature_key)
    out: dict[str, dict] = {}
    for feature in names:
        blades = [b for b, v in per_blade if feature in v]
        x = np.array([v[feature] for _, v in per_blade if feature in v], float)
        lsl, usl = _limits_for(feature, limits)
        entry = {"n": int(x.size), "mean": float(np.mean(x)),
                 "std": float(np.std(x, ddof=1)) if x.size > 1 else None,
                 "min": float(np.min(x)), "max": float(np.max(x)),
                 "worst": _worst(blades, x, lsl, usl)}
        if lsl is not None or usl is not None:
            entry.update(capability(x, lsl, usl))
        out[feature] = entry
    return out


def _limits_for(feature: str, limits: dict) -> tuple[float | None, float | None]:
    """Limits by the full name, or for section parameters by ``section.*.<parameter>``."""
    if feature in limits:
        return tuple(limits[feature])
    parts = feature.split(".")
    if parts[0] == "section" and len(parts) == 3 and f"section.*.{parts[2]}" in limits:
        return tuple(limits[f"section.*.{parts[2]}"])
    return None, None


def _feature_key(name: str):
    group, _, rest = name.partition(".")
    rank = {"deviation": 0, "section": 1, "position": 2}.get(group, 3)
    if group == "deviation" and rest in DEVIATION_FEATURES:
        return rank, DEVIATION_FEATURES.index(rest), "", ""
    if group == "section":
        index, _, param = rest.partition(".")
        return rank, int(index) if index.isdigit() else 10**9, index, param
    return rank, 0, rest, ""
