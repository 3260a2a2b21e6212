# SPDX-License-Identifier: LGPL-2.1-or-later
"""The polynomial models and start grids of the few splines projected onto last, kept so
that re-projecting onto the same nominal costs no rebuild (``_cache``, newest last).
"""
from __future__ import annotations

import threading

from bladerecon.core.geometry.projection.evaluation import _SurfaceModel
from bladerecon.core.geometry.projection.grid import _SurfaceGrid
from bladerecon.core.geometry.spline import BSplineSurface

__all__ = ["_cached", "_surface_grid", "_cache", "_cache_lock", "_CACHE_SIZE"]

_CACHE_SIZE = 4
_cache: list[tuple[object, object, list]] = []     # (spline, model, [grid or None]), newest last
_cache_lock = threading.Lock()


def _cached(spline, make_model):
    """The polynomial model of a spline, and a slot for its start grid, kept for the few
    splines used last: re-projecting onto the same nominal (alignment iterations, restarts,
    a second point set) then costs no rebuild. Splines are frozen dataclasses, so the
    object identity is the key; the entry holds the spline, so the id is not reused."""
    with _cache_lock:
        for k, (obj, model, slot) in enumerate(_cache):
            if obj is spline:
                _cache.append(_cache.pop(k))
                return model, slot
    model, slot = make_model(spline), [None]
    with _cache_lock:
        _cache.append((spline, model, slot))
        del _cache[:-_CACHE_SIZE]
    return model, slot


def _surface_grid(surface: BSplineSurface) -> tuple[_SurfaceModel, _SurfaceGrid]:
    model, slot = _cached(surface, _SurfaceModel)
    if slot[0] is None:
        slot[0] = _SurfaceGrid(model)
    return model, slot[0]
