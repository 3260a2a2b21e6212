# SPDX-License-Identifier: LGPL-2.1-or-later
"""Unordered point clouds -> blade sections: slicing by planes or by cylinders (issue 6 §5).

A laser scan or a CFD surface mesh gives points with no section structure. Sections are cut
out of it:

* **planes** normal to an axis (``--slice N`` equally spaced, or ``--slice-at z1,z2,...``),
  a slab of width ``slab`` (mm) around each plane;
* **cylinders** about a rotor axis (``--slice-radii r1,r2,...``), a shell of width ``slab``
  around each radius — rotor blades are measured and designed on surfaces of revolution.

The points of a slab are moved onto the cutting plane (along the axis) or cylinder (along
the radius): the blade surface contains the span direction to first order, so this slides a
point along the surface rather than off it; ``project=False`` keeps them where they are.

In each slab the points are split into connected groups (neighbours closer than
``link`` · the median nearest-neighbour distance): a second group of comparable size means
the slab caught two blades (an error); small groups are outliers, removed and reported.
Ordering along the section is left to :func:`bladerecon.core.sections.ordering.build_sections`
(camber-line order, the same as for any unordered section).

Units: mm.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.readers import PointSet

__all__ = ["Slice", "read_cloud", "plane_positions", "slice_planes", "slice_cylinders", "slices_to_pointset",
           "MIN_SLICE_POINTS"]

MIN_SLICE_POINTS = 12
#: a default slab holds about this many points (fewer when the cloud is sparse)
SLAB_POINTS = 3000


@dataclass(frozen=True)
class Slice:
    """The points of one slab, moved onto its cutting surface (mm)."""

    position: float            # plane height along the axis, or cylinder radius (mm)
    points: np.ndarray         # (n, 3) kept points
    index: np.ndarray          # (n,) row of each kept point in the cloud
    outliers: np.ndarray       # rows in the cloud of the points removed as outliers
    kind: str                  # "plane" | "cylinder"
    slab: float = 0.0          # width of the slab the points came from (mm)


def read_cloud(path: str, scale: float = 1.0, memory_limit: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Points of an unordered cloud: any file :func:`~bladerecon.core.io.readers.read_points`
    reads (a CSV with a header, lines of 3 numbers x y z or 4 id x y z, '#' comments, a PLY or
    PCD scan), or rows x,y,z / id,x,y,z with commas and no header; read a block at a time.

    ``scale`` multiplies the coordinates (1000 for a file in metres). Returns ``(points (N, 3)
    mm, line numbers (N,))``.
    """
    from bladerecon.core.io.readers import headerless_rows, read_headerless_cloud, read_points

    if headerless_rows(path):                                 # x,y,z rows as scanners write them
        ps = read_headerless_cloud(path, memory_limit)
    else:
        ps = read_points(path, require_sections=False, memory_limit=memory_limit)   # read in blocks
    if len(ps.points) < MIN_SLICE_POINTS:
        raise BladeReconError(f"{path}: {len(ps.points)} points; a cloud to slice needs many more")
    P = np.asarray(ps.points, float) * scale
    if not np.all(np.isfinite(P)):
        raise BladeReconError(f"{path}: the cloud holds NaN or infinite coordinates")
    return P, np.asarray(ps.line)


def plane_positions(points: np.ndarray, axis: np.ndarray, n: int, margin: float = 0.05) -> np.ndarray:
    """``n`` equally spaced plane heights (mm) along ``axis``, ``margin`` of the extent kept off each end."""
    if n < 2:
        raise BladeReconError(f"--slice {n}: need at least 2 slices for a surface")
    h = np.asarray(points) @ axis
    lo, hi = h.min(), h.max()
    return np.linspace(lo + margin * (hi - lo), hi - margin * (hi - lo), n)


def _default_slab(positions: np.ndarray, heights: np.ndarray | None = None) -> float:
    """A quarter of the smallest gap between the cuts; with the points' ``heights`` along the
    axis (or radii), no wider than holds about :data:`SLAB_POINTS` points: a thick slab of a
    dense scan only adds the error of moving its points onto the cut."""
    p = np.sort(np.asarray(positions, float))
    slab = 0.25 * float(np.diff(p).min()) if p.size > 1 else 1.0
    if heights is not None and len(heights) and p.size:
        near = [np.count_nonzero(np.abs(heights - z) <= 0.5 * slab) for z in p]
        dense = int(np.median(near))
        if dense > SLAB_POINTS:
            slab *= SLAB_POINTS / dense
    return slab


def _groups(points: np.ndarray, link: float, extent_share: float = 0.08) -> tuple[np.ndarray, np.ndarray]:
    """Connected groups (labels, sizes): points closer than the link distance are joined.

    The link distance is the larger of ``link`` x the median nearest-neighbour distance and
    ``extent_share`` of the slab's size (bounding-box diagonal): randomly spaced scan points
    leave gaps of many median spacings along a section, but not of 8 % of the blade, and
    neighbouring blades stand a passage width apart.
    """
    tree = cKDTree(points)
    d, _ = tree.query(points, 2)
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    r = max(link * float(np.median(d[:, 1])), extent_share * size)
    del tree, d
    labels = _components_within(points, r)
    return labels, np.bincount(labels)


def _components_within(points: np.ndarray, r: float) -> np.ndarray:
    """Connected components (a label per point) of the graph joining points closer than ``r``,
    without listing the pairs: with ``r`` a share of the slab, every point has a share of the
    slab as neighbours and the pairs grow with the square of the points (5.5 GB for a slab of
    130 000 points). Points in one cube of side r/sqrt(3) are all within ``r`` of each other:
    a cube is one node; two cubes at most two apart along every axis are joined when their
    nearest points are within ``r`` (a k-d tree query of one cube's points against the other's).
    The components of the pairs within ``r`` (points exactly ``r`` apart may be joined where
    the pairs' squared-distance test, rounded, does not); memory linear in the points."""
    n = points.shape[0]
    if n == 0:
        return np.zeros(0, dtype=int)
    if not r > 0:
        return np.arange(n)
    h = r / np.sqrt(3.0) * (1.0 - 1e-9)
    cells = (points - points.min(axis=0)) / h
    if not np.all(cells < 2.0 ** 40):          # r far below the cloud's size: few pairs, list them
        pairs = cKDTree(points).query_pairs(r, output_type="ndarray")
        g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        return connected_components(g, directed=False)[1]
    keys = np.floor(cells).astype(np.int64)
    cubes, cube = np.unique(keys, axis=0, return_inverse=True)
    cube = cube.ravel()
    order = np.argsort(cube, kind="stable")
    bounds = np.searchsorted(cube[order], np.arange(len(cubes) + 1))
    members = [order[bounds[c]:bounds[c + 1]] for c in range(len(cubes))]
    index = {tuple(k): c for c, k in enumerate(cubes.tolist())}
    parent = list(range(len(cubes)))

    def root(c: int) -> int:
        while parent[c] != c:
            parent[c] = parent[parent[c]]
            c = parent[c]
        return c

    trees: dict[int, cKDTree] = {}
    offsets = [(i, j, k) for i in range(-2, 3) for j in range(-2, 3) for k in range(-2, 3) if (i, j, k) > (0, 0, 0)]
    for c, key in enumerate(cubes.tolist()):
        for off in offsets:
            other = index.get((key[0] + off[0], key[1] + off[1], key[2] + off[2]))
            if other is None:
                continue
            a, b = root(c), root(other)
            if a == b:
                continue
            small, big = (c, other) if len(members[c]) <= len(members[other]) else (other, c)
            if big not in trees:
                trees[big] = cKDTree(points[members[big]])
            dist, _ = trees[big].query(points[members[small]], k=1, distance_upper_bound=np.nextafter(r, np.inf))
            if np.any(dist <= r):                 # as query_pairs: at most r
                parent[a] = b
    roots = np.array([root(c) for c in range(len(cubes))])
    _, compact = np.unique(roots, return_inverse=True)
    return compact.ravel()[cube]


def _clean(points: np.ndarray, rows: np.ndarray, where: str, link: float, two_blade_share: float) -> tuple:
    """Split a slab into groups: the largest is the section, a second large one is an error."""
    labels, sizes = _groups(points, link)
    order = np.argsort(-sizes)
    if sizes.size > 1 and sizes[order[1]] >= two_blade_share * points.shape[0]:
        raise BladeReconError(
            f"{where}: the slab holds two separate groups of {sizes[order[0]]} and {sizes[order[1]]} points "
            "(two blades?): crop the cloud to one blade, or narrow the slice range")
    keep = labels == order[0]
    return points[keep], rows[keep], rows[~keep]


def _finish(kind: str, pos: float, P: np.ndarray, rows: np.ndarray, where: str, link: float,
            two_blade_share: float, min_points: int, slab: float = 0.0) -> Slice:
    if P.shape[0] < min_points:
        raise BladeReconError(f"{where}: {P.shape[0]} points in the slab, a section needs at least {min_points}: "
                              "widen --slab or move the slice")
    P, kept, out = _clean(P, rows, where, link, two_blade_share)
    if P.shape[0] < min_points:
        raise BladeReconError(f"{where}: {P.shape[0]} points left after removing outliers, needs at least "
                              f"{min_points}: widen --slab")
    return Slice(float(pos), P, kept, out, kind, slab)


def slice_planes(points: np.ndarray, positions, axis=(0.0, 0.0, 1.0), slab: float | None = None,
                 project: bool = True, link: float = 6.0, two_blade_share: float = 0.2,
                 min_points: int = MIN_SLICE_POINTS) -> list[Slice]:
    """Slabs of width ``slab`` (mm; default a quarter of the smallest gap, narrower on a dense
    cloud: :func:`_default_slab`) around planes
    normal to ``axis`` at heights ``positions`` (mm), points moved onto the planes."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    pos = np.asarray(positions, float)
    P = np.asarray(points, float)
    h = P @ a
    slab = _default_slab(pos, h) if slab is None else float(slab)
    if not slab > 0:
        raise BladeReconError(f"--slab must be a positive width in mm, got {slab}")
    out = []
    for z in pos:
        m = np.flatnonzero(np.abs(h - z) <= 0.5 * slab)
        Q = _onto_plane(P[m], h[m] - z, a) if project else P[m]
        out.append(_finish("plane", z, Q, m, f"slice at {z:.4f} mm", link, two_blade_share, min_points, slab))
    return out


#: neighbours that give a point's tangent plane when it is moved onto its cut
_TANGENT_NEIGHBOURS = 10
#: a tangent plane steeper than this to the cut (|n . axis|, 60 degrees) is a cap, not the
#: blade's wall: such points, and points whose neighbours are not flat (the two sides of a thin
#: edge), are moved straight along the axis
_MAX_TILT = 0.5
_MAX_THICKNESS = 0.1      # smallest / middle spread of the neighbours: flat enough
_DRIFT_NEIGHBOURS = 40    # drifts whose median moves a point
_MIN_WIDTH = 0.05         # middle / largest spread of the neighbours: not all on one line
_MIN_VALID = 0.25          # share of the neighbours with a drift for the median to be used


def _onto_plane(P: np.ndarray, offset: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Points of a slab moved onto the cut plane along the surface they lie on, not along the
    axis: a point ``offset`` above the plane slides down its tangent plane (from its nearest
    neighbours in the slab) until it reaches the cut. Moving straight along the axis puts a
    point of a twisted or leaning wall off the section by ``offset`` x the wall's slope (2 mm
    from the sample blade at the default slab); along the tangent plane the error is second
    order in the offset (the wall's spanwise curvature)."""
    n = P.shape[0]
    straight = P - np.outer(offset, a)
    if n < _TANGENT_NEIGHBOURS + 1:
        return straight
    _, nb = cKDTree(P).query(P, _TANGENT_NEIGHBOURS)
    drift = np.full((n, 3), np.nan)                    # in-plane move per mm of offset, beyond the axis
    for lo in range(0, n, 65536):                      # in blocks: (block, k, 3) neighbour arrays
        Q = P[nb[lo:lo + 65536]]
        X = Q - Q.mean(axis=1, keepdims=True)
        w, v = np.linalg.eigh(np.einsum("mki,mkj->mij", X, X))
        normal = v[:, :, 0]
        tilt = normal @ a
        d = a - tilt[:, None] * normal                 # the axis within the tangent plane
        # flat (a plane, not the two sides of a thin edge) and two-dimensional (not one scan
        # line: ten neighbours along a line leave the normal to the noise)
        ok = ((w[:, 0] <= _MAX_THICKNESS * np.maximum(w[:, 1], 1e-300))
              & (w[:, 1] >= _MIN_WIDTH * w[:, 2]) & (np.abs(tilt) <= _MAX_TILT))
        g = d / (1.0 - tilt ** 2)[:, None] - a         # sign-free: the same for -normal
        drift[lo:lo + len(Q)][ok] = g[ok]
    # one normal from ten neighbours 0.1-0.3 mm apart tilts by noise / spacing: times a 2 mm
    # offset that is tens of µm. The drift varies slowly along the section: the median of the
    # drifts around each point (in the cut, where the neighbours of a thin edge's two sides
    # are told apart by the flatness test above) keeps the wall's slope and drops the noise
    _, near = cKDTree(straight).query(straight, min(_DRIFT_NEIGHBOURS, n))
    smooth = np.full((n, 3), np.nan)
    for lo in range(0, n, 16384):                      # in blocks: (block, 40, 3) drifts
        around = drift[near[lo:lo + 16384]]
        valid = np.isfinite(around[:, :, 0]).sum(axis=1)
        with warnings.catch_warnings():                # no drift around a point: moved straight
            warnings.simplefilter("ignore", RuntimeWarning)
            med = np.nanmedian(around, axis=1)
        med[valid < _MIN_VALID * around.shape[1]] = np.nan    # a few stray drifts are not a median
        smooth[lo:lo + 16384] = med
    smooth -= (smooth @ a)[:, None] * a                # in the cut (the median of in-plane vectors is not)
    smooth[~np.all(np.isfinite(smooth), axis=1)] = 0.0     # no drift: moved straight
    return straight - offset[:, None] * smooth


def slice_cylinders(points: np.ndarray, radii, axis=(0.0, 0.0, 1.0), centre=(0.0, 0.0, 0.0),
                    slab: float | None = None, project: bool = True, link: float = 6.0,
                    two_blade_share: float = 0.2, min_points: int = MIN_SLICE_POINTS) -> list[Slice]:
    """Shells of width ``slab`` (mm) around cylinders of the given radii (mm) about the axis
    through ``centre``; points moved radially onto the cylinders."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    c = np.asarray(centre, float)
    rad = np.asarray(radii, float)
    if np.any(rad <= 0):
        raise BladeReconError("--slice-radii must be positive radii in mm")
    P = np.asarray(points, float)
    d = P - c
    along = d @ a
    radial = d - np.outer(along, a)
    r = np.linalg.norm(radial, axis=1)
    slab = _default_slab(rad, r) if slab is None else float(slab)
    if not slab > 0:
        raise BladeReconError(f"--slab must be a positive width in mm, got {slab}")
    out = []
    for rk in rad:
        m = np.flatnonzero(np.abs(r - rk) <= 0.5 * slab)
        Q = c + np.outer(along[m], a) + radial[m] * (rk / r[m])[:, None] if project else P[m]
        out.append(_finish("cylinder", rk, Q, m, f"cylinder slice at r = {rk:.4f} mm", link,
                           two_blade_share, min_points, slab))
    return out


def slices_to_pointset(slices: list[Slice], lines: np.ndarray, source: str) -> PointSet:
    """The slices as a :class:`PointSet` (one section per slice) for ``build_sections``.

    A point caught by two slabs is an error (the slabs overlap): narrow ``--slab``.
    """
    rows = np.concatenate([s.index for s in slices])
    if np.unique(rows).size != rows.size:
        raise BladeReconError(f"{source}: neighbouring slabs share points: narrow --slab")
    pts = np.concatenate([s.points for s in slices])
    sec = np.concatenate([np.full(len(s.points), k) for k, s in enumerate(slices)])
    names = tuple(f"{s.kind}@{s.position:.3f}" for s in slices)
    return PointSet(pts, sec, np.asarray(lines)[rows], names, source, "cloud-slices")
