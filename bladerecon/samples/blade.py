# SPDX-License-Identifier: LGPL-2.1-or-later
"""An analytic blade whose true surface is known exactly: the sample for demo, tests, benchmarks.

Units: millimetres and degrees at every interface (radians only inside).

Geometry
========
A section at span fraction ``h`` in [0, 1] lies in the plane ``z = hub_z + span*h``
(planar sections, so the hub and tip caps are planar). In the section's own frame
(x along the chord from the LE point, y to the suction side) it is built like this:

* **Camber line**: a circular arc of camber angle ``theta(h)`` from the LE-circle centre
  ``(r_LE, 0)`` to the TE-circle centre ``(c - r_TE, 0)``, bulging towards +y.
  ``xi`` in [0, 1] is the fraction of its arc length ``L``; angle ``alpha = theta*(xi - 1/2)``,
  radius ``rho = (c - r_LE - r_TE) / (2 sin(theta/2))``, unit tangent ``T = (cos a, -sin a)``,
  unit normal ``N = (sin a, cos a)`` (towards the suction side).
* **Half thickness** (a cubic, C-infinity)::

      R(xi) = r_LE (1 - xi) + r_TE xi + xi (1 - xi) (k0 + k1 xi)

  with ``k0, k1`` solved (2x2, closed form) so that ``R(m) = t_max/2`` and ``R'(m) = 0``
  at ``m = tmax_position`` (0.4): the maximum thickness sits exactly at 40 % of the
  camber line.
* **Disk envelope**: the blade section is the union of the disks of radius ``R(xi)``
  centred on the camber line. Its boundary is

  - the two envelope flanks ``E = C + R u``, ``u = -s T +/- sqrt(1 - s^2) N``,
    ``s = R'(xi) / L`` (``+`` suction side, ``-`` pressure side); ``u`` is also the
    outward unit normal of the flank;
  - the arcs of the two end disks (the LE circle of radius ``r_LE``, the TE circle of
    radius ``r_TE``) between the flanks' touching points. The edges join the flanks
    tangentially (G1) with a curvature jump, as on a machined blade.

* **Chord** ``c(h)`` is the distance from the LE point (the LE-circle point farthest from
  the TE along the chord, local ``(0, 0)``) to the TE point (local ``(c, 0)``).
* **Stacking**: the section is rotated by the stagger angle ``stagger_hub + twist*h``
  about its chord mid-point, which is then moved to ``(sweep_tip*h^2, lean_tip*h^2)``
  (x axial sweep, y tangential lean).

Every law in ``h`` is a polynomial or a sine/cosine of one, so a point is computed in
closed form: it lies on the true surface to float64 round-off (~1e-14 mm).

Profile parameter
=================
``t`` in [0, 1) is periodic, ``t = 0`` at the LE point, running counter-clockwise about +z:
LE circle (lower part) -> pressure flank (``xi`` 0 -> 1) -> TE circle -> suction flank
(``xi`` 1 -> 0) -> LE circle (upper part). Each of the five pieces gets a share of ``t``
proportional to its (approximate) length and is linear in its own angle or ``xi``, so
``t`` is close to normalised arc length but is not it; use :func:`t_at_length_fraction`
for exact arc-length positions. The outward normal is ``dS/dt x dS/dh`` normalised.

The surface normal is ``span*u - (u . dC/dh + dR/dh) z^`` normalised: only the normal
speed of the section matters, and for an envelope of disks that is the normal speed of
the touching disk. ``dC/dh`` and ``dR/dh`` (at fixed ``xi``) are taken by the complex-step
derivative (Squire & Trapp 1998), which has no subtractive cancellation: its truncation
error ~1e-40 is far below float64 round-off, so the normal is exact too.

Default numbers: chord 56 -> 52 mm, t_max 9.5 % -> 6 % chord, camber 38 -> 26 deg,
r_LE 0.9 -> 0.7 mm, r_TE 0.6 -> 0.45 mm (hub -> tip, linear in h), stagger 30 deg at the
hub plus 25 deg of twist, sweep 4 mm and lean 3 mm at the tip, span 100 mm.

Samples
=======
:func:`sample_sections` gives measured-like sections ('uniform': equally spaced in arc
length from a random start; 'plan': a sparse measurement plan, see there),
:func:`dense_truth` / :func:`nominal_grid` the true surface on and between them.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from bladerecon.core.errors import BladeReconError

__all__ = [
    "nominal_surface",
    "SampleBlade",
    "SectionLaws",
    "section_heights",
    "t_at_length_fraction",
    "sample_sections",
    "nominal_grid",
    "dense_truth",
]

_DEG = np.pi / 180.0
_COMPLEX_STEP = 1e-20                    # complex-step size for d/dh (exact to round-off)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_GL_X = 0.5 * (_GL_X + 1.0)              # Gauss-Legendre nodes/weights on [0, 1]
_GL_W = 0.5 * _GL_W
_N_PIECES = 5                            # LE lower, pressure flank, TE, suction flank, LE upper


class SectionLaws(NamedTuple):
    """The section's parameters at span fraction(s) h (mm and degrees)."""

    chord: np.ndarray
    camber: np.ndarray
    max_thickness: np.ndarray
    le_radius: np.ndarray
    te_radius: np.ndarray
    stagger: np.ndarray
    sweep: np.ndarray
    lean: np.ndarray
    z: np.ndarray


class _Section(NamedTuple):
    """Everything a section needs, for an array of h (real, or complex for d/dh)."""

    chord: np.ndarray
    theta: np.ndarray        # camber angle, rad
    r_le: np.ndarray
    r_te: np.ndarray
    stagger: np.ndarray      # rad
    x_off: np.ndarray
    y_off: np.ndarray
    z: np.ndarray
    rho: np.ndarray          # camber-arc radius
    lcam: np.ndarray         # camber-arc length L
    k0: np.ndarray           # half-thickness coefficients
    k1: np.ndarray
    beta_le: np.ndarray      # asin(R'/L) at the LE / TE end
    beta_te: np.ndarray
    widths: np.ndarray       # (..., 5) share of t of each piece
    bounds: np.ndarray       # (..., 6) t at the piece joints, 0 .. 1

    def take(self, index) -> "_Section":
        return _Section(*(f[index] for f in self))

    def expand(self) -> "_Section":
        """Add a trailing axis to every per-h field (to broadcast against node arrays)."""
        return _Section(*(f[..., None] for f in self))


@dataclass(frozen=True)
class SampleBlade:
    """An analytic compressor-like blade, exact at every span height (mm, degrees).

    Hub/tip pairs vary linearly in the span fraction h; see the module docstring.
    """

    span: float = 100.0
    hub_z: float = 0.0
    chord_hub: float = 56.0
    chord_tip: float = 52.0
    camber_hub: float = 38.0
    camber_tip: float = 26.0
    thickness_hub: float = 0.095          # t_max / chord
    thickness_tip: float = 0.060
    tmax_position: float = 0.4            # fraction of the camber line
    le_radius_hub: float = 0.9
    le_radius_tip: float = 0.7
    te_radius_hub: float = 0.6
    te_radius_tip: float = 0.45
    stagger_hub: float = 30.0
    twist: float = 25.0
    sweep_tip: float = 4.0
    lean_tip: float = 3.0

    def __post_init__(self) -> None:
        _check_blade(self)

    # ------------------------------------------------------------------ span laws
    def z_of(self, h):
        """Height z (mm) of the section plane at span fraction(s) h."""
        return self.hub_z + self.span * np.asarray(h, dtype=float)

    def h_of_z(self, z):
        """Span fraction of the section plane at height(s) z (mm); inverse of :meth:`z_of`."""
        return (np.asarray(z, dtype=float) - self.hub_z) / self.span

    def section_laws(self, h) -> SectionLaws:
        """Chord, camber, max thickness, edge radii, stagger, sweep, lean, z at h."""
        s = _section(self, np.asarray(h, dtype=float))
        tmax = 2.0 * _half_thickness(s, self.tmax_position)[0]
        return SectionLaws(s.chord, s.theta / _DEG, tmax, s.r_le, s.r_te, s.stagger / _DEG,
                           s.x_off, s.y_off, s.z)

    # ------------------------------------------------------------------ surface
    def point(self, h, t) -> np.ndarray:
        """True surface point(s) (..., 3) mm at span fraction h, profile parameter t."""
        return self._evaluate(h, t)["point"]

    def normal(self, h, t) -> np.ndarray:
        """Unit outward surface normal(s) (..., 3) at (h, t): dS/dt x dS/dh normalised."""
        return self._evaluate(h, t, with_normal=True)["normal"]

    def curvature(self, h, t) -> np.ndarray:
        """Signed curvature (1/mm) of the section curve at (h, t), > 0 where convex."""
        return self._evaluate(h, t)["curvature"]

    def camber_point(self, h, xi) -> np.ndarray:
        """Point(s) (..., 3) on the camber line at arc-length fraction xi (0 LE, 1 TE)."""
        h, xi = np.broadcast_arrays(np.asarray(h, dtype=float), np.asarray(xi, dtype=float))
        s = _section(self, h)
        return _to_global(s, _camber_local(s, xi))

    def half_thickness(self, h, xi) -> np.ndarray:
        """Disk radius R (mm) at camber-line fraction xi: half the local thickness."""
        h, xi = np.broadcast_arrays(np.asarray(h, dtype=float), np.asarray(xi, dtype=float))
        return _half_thickness(_section(self, h), xi)[0]

    def segment_bounds(self, h) -> np.ndarray:
        """(..., 6) values of t at the piece joints: 0, LE|pressure, pressure|TE,
        TE|suction, suction|LE, 1. The LE arc is t < b[1] or t >= b[4]; the TE arc is
        b[2] <= t < b[3]."""
        return _section(self, np.asarray(h, dtype=float)).bounds

    def le_te(self, h) -> tuple[np.ndarray, np.ndarray]:
        """LE and TE points (..., 3): the edge-circle points farthest apart along the chord.

        The LE point is the point at t = 0; the TE point is at :meth:`te_parameter`.
        """
        s = _section(self, np.asarray(h, dtype=float))
        zero = np.zeros_like(s.chord)
        le = _to_global(s, np.stack([zero, zero], axis=-1))
        te = _to_global(s, np.stack([s.chord, zero], axis=-1))
        return le, te

    def te_parameter(self, h) -> np.ndarray:
        """Profile parameter t of the TE point at span fraction(s) h."""
        s = _section(self, np.asarray(h, dtype=float))
        start = -s.theta / 2 - np.pi / 2 - s.beta_te       # angle where the TE arc starts
        sigma = -start / (np.pi + 2 * s.beta_te)
        return s.bounds[..., 2] + s.widths[..., 2] * sigma

    def section_length(self, h) -> np.ndarray:
        """Perimeter (mm) of the section at span fraction(s) h.

        Edge arcs in closed form; flanks by composite Gauss-Legendre (32 panels x 8 nodes)
        of the exact speed, which is analytic: exact to round-off.
        """
        s = _section(self, np.asarray(h, dtype=float))
        arcs = (s.r_le * (np.pi - 2 * s.beta_le) + s.r_te * (np.pi + 2 * s.beta_te))
        panels = 32
        xi = ((np.arange(panels)[:, None] + _GL_X[None, :]) / panels).ravel()
        w = np.tile(_GL_W, panels) / panels
        e = s.expand()
        flanks = sum((_flank(e, xi, side)["speed"] * w).sum(axis=-1) for side in (-1.0, 1.0))
        return arcs + flanks

    # ------------------------------------------------------------------ evaluation
    def _evaluate(self, h, t, with_normal: bool = False) -> dict[str, np.ndarray]:
        h, t = np.broadcast_arrays(np.asarray(h, dtype=float), np.asarray(t, dtype=float))
        shape = h.shape
        h, t = h.ravel(), np.mod(t.ravel(), 1.0)
        s = _section(self, h)
        piece = np.clip((t[:, None] >= s.bounds[:, 1:_N_PIECES]).sum(axis=1), 0, _N_PIECES - 1)
        rows = np.arange(h.size)
        sigma = (t - s.bounds[rows, piece]) / s.widths[rows, piece]
        out = _evaluate_pieces(s, piece, sigma)
        result = {"point": _to_global(s, out["p"]).reshape(shape + (3,)),
                  "curvature": out["curvature"].reshape(shape)}
        if with_normal:
            result["normal"] = _surface_normal(self, s, h, out).reshape(shape + (3,))
        return result


# ---------------------------------------------------------------------- section laws
def _section(blade: SampleBlade, h: np.ndarray) -> _Section:
    """All section quantities at h; complex-analytic in h (used for the complex step)."""
    def lerp(hub, tip):
        return hub + (tip - hub) * h

    chord = lerp(blade.chord_hub, blade.chord_tip)
    theta = lerp(blade.camber_hub, blade.camber_tip) * _DEG
    r_le = lerp(blade.le_radius_hub, blade.le_radius_tip)
    r_te = lerp(blade.te_radius_hub, blade.te_radius_tip)
    t_max = lerp(blade.thickness_hub, blade.thickness_tip) * chord
    stagger = (blade.stagger_hub + blade.twist * h) * _DEG
    x_off = blade.sweep_tip * h ** 2
    y_off = blade.lean_tip * h ** 2
    z = blade.hub_z + blade.span * h

    rho = (chord - r_le - r_te) / (2.0 * np.sin(theta / 2))
    lcam = rho * theta
    # R(m) = t_max/2 and R'(m) = 0: linear in (k0, k1), determinant m^2 (1-m)^2.
    m = blade.tmax_position
    rhs_h = t_max / 2 - r_le * (1 - m) - r_te * m
    slope = r_te - r_le
    det = (m * (1 - m)) ** 2
    k0 = (rhs_h * m * (2 - 3 * m) + slope * m * m * (1 - m)) / det
    k1 = (-slope * m * (1 - m) - rhs_h * (1 - 2 * m)) / det
    beta_le = np.arcsin((slope + k0) / lcam)
    beta_te = np.arcsin((slope - k0 - k1) / lcam)

    # Share of t: arcs exactly, flanks as offsets of the camber arc by the mean R.
    r_mean = (r_le + r_te) / 2 + k0 / 6 + k1 / 12
    lengths = np.stack([r_le * (theta / 2 + np.pi / 2 - beta_le),
                        lcam - theta * r_mean,
                        r_te * (np.pi + 2 * beta_te),
                        lcam + theta * r_mean,
                        r_le * (np.pi / 2 - theta / 2 - beta_le)], axis=-1)
    widths = lengths / lengths.sum(axis=-1, keepdims=True)
    bounds = np.concatenate([np.zeros_like(widths[..., :1]), np.cumsum(widths, axis=-1)], axis=-1)
    bounds[..., -1] = 1.0
    return _Section(chord, theta, r_le, r_te, stagger, x_off, y_off, z, rho, lcam, k0, k1,
                    beta_le, beta_te, widths, bounds)


def _half_thickness(s: _Section, xi):
    """R, R', R'' (d/dxi) of the cubic half-thickness law."""
    xi = np.asarray(xi)
    bump = s.k0 + s.k1 * xi
    r = s.r_le * (1 - xi) + s.r_te * xi + xi * (1 - xi) * bump
    dr = (s.r_te - s.r_le) + (1 - 2 * xi) * bump + xi * (1 - xi) * s.k1
    ddr = -2 * s.k0 + 2 * s.k1 - 6 * s.k1 * xi
    return r, dr, ddr


def _camber_frame(s: _Section, xi):
    """Camber arc angle alpha and unit tangent T, normal N (local frame, (..., 2))."""
    alpha = s.theta * (np.asarray(xi) - 0.5)
    tangent = np.stack([np.cos(alpha), -np.sin(alpha)], axis=-1)
    normal = np.stack([np.sin(alpha), np.cos(alpha)], axis=-1)
    return alpha, tangent, normal


def _camber_local(s: _Section, xi) -> np.ndarray:
    alpha = s.theta * (np.asarray(xi) - 0.5)
    half = s.theta / 2
    x = s.r_le + s.rho * (np.sin(half) + np.sin(alpha))
    # rho (cos alpha - cos half), written without cancellation
    y = -2 * s.rho * np.sin((alpha + half) / 2) * np.sin((alpha - half) / 2)
    return np.stack([x, y], axis=-1)


def _to_global(s: _Section, p: np.ndarray) -> np.ndarray:
    """Local section frame (..., 2) -> global (..., 3): stagger about mid-chord, offsets, z."""
    x = p[..., 0] - s.chord / 2
    y = p[..., 1]
    c, sn = np.cos(s.stagger), np.sin(s.stagger)
    return np.stack([s.x_off + c * x - sn * y, s.y_off + sn * x + c * y,
                     s.z + np.zeros_like(x)], axis=-1)


def _rotate(s: _Section, v: np.ndarray) -> np.ndarray:
    c, sn = np.cos(s.stagger), np.sin(s.stagger)
    return np.stack([c * v[..., 0] - sn * v[..., 1], sn * v[..., 0] + c * v[..., 1]], axis=-1)


# ---------------------------------------------------------------------- profile pieces
def _flank(s: _Section, xi, side: float) -> dict[str, np.ndarray]:
    """Envelope flank (side +1 suction, -1 pressure) at camber fraction xi.

    Returns local point, outward normal u, speed |dE/dxi| and signed curvature.
    """
    _, tan, nor = _camber_frame(s, xi)
    r, dr, ddr = _half_thickness(s, xi)
    sn = dr / s.lcam
    ds = ddr / s.lcam
    cs = side * np.sqrt(1 - sn * sn)
    dcs = -side * sn * ds / np.sqrt(1 - sn * sn)
    u = -sn[..., None] * tan + cs[..., None] * nor
    # dT/dxi = -theta N, dN/dxi = theta T
    du = ((cs * s.theta - ds)[..., None] * tan + (sn * s.theta + dcs)[..., None] * nor)
    de = s.lcam[..., None] * tan + dr[..., None] * u + r[..., None] * du
    speed = np.linalg.norm(de, axis=-1)
    curvature = (du * de).sum(axis=-1) / speed ** 2
    return {"p": _camber_local(s, xi) + r[..., None] * u, "u": u, "speed": speed,
            "curvature": curvature}


def _edge_arc(s: _Section, piece: int, sigma) -> dict[str, np.ndarray]:
    """LE (pieces 0, 4) or TE (piece 2) circle arc at fraction sigma of the piece."""
    half = s.theta / 2
    if piece == 0:
        phi = np.pi + sigma * (half + np.pi / 2 - s.beta_le)
        centre, r, sweep = s.r_le, s.r_le, half + np.pi / 2 - s.beta_le
    elif piece == 4:
        phi = half + np.pi / 2 + s.beta_le + sigma * (np.pi / 2 - half - s.beta_le)
        centre, r, sweep = s.r_le, s.r_le, np.pi / 2 - half - s.beta_le
    else:
        phi = -half - np.pi / 2 - s.beta_te + sigma * (np.pi + 2 * s.beta_te)
        centre, r, sweep = s.chord - s.r_te, s.r_te, np.pi + 2 * s.beta_te
    u = np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    p = np.stack([centre + r * u[..., 0], r * u[..., 1]], axis=-1)
    return {"p": p, "u": u, "speed": r * sweep + 0 * phi, "curvature": 1 / r + 0 * phi}


def _piece(s: _Section, piece: int, sigma) -> dict[str, np.ndarray]:
    """Local geometry of one piece at fraction sigma in [0, 1]; 'speed' is |dp/dsigma|."""
    sigma = np.asarray(sigma, dtype=float)
    if piece in (1, 3):
        xi = sigma if piece == 1 else 1 - sigma
        out = _flank(s, xi, -1.0 if piece == 1 else 1.0)
    else:
        out = _edge_arc(s, piece, sigma)
        xi = np.zeros_like(sigma) if piece != 2 else np.ones_like(sigma)
    out["xi"] = xi + 0 * out["speed"]
    return out


def _evaluate_pieces(s: _Section, piece: np.ndarray, sigma: np.ndarray) -> dict[str, np.ndarray]:
    """Evaluate flat arrays (one row of s per point), one masked pass per piece."""
    n = sigma.size
    out = {"p": np.empty((n, 2)), "u": np.empty((n, 2)), "speed": np.empty(n),
           "curvature": np.empty(n), "xi": np.empty(n)}
    for k in range(_N_PIECES):
        mask = piece == k
        if mask.any():
            part = _piece(s.take(mask), k, sigma[mask])
            for key in out:
                out[key][mask] = part[key]
    return out


def _surface_normal(blade: SampleBlade, s: _Section, h: np.ndarray, out) -> np.ndarray:
    """n ~ span*u - (u . dC/dh + dR/dh) z^, with dC/dh, dR/dh at fixed xi by complex step."""
    sc = _section(blade, h + 1j * _COMPLEX_STEP)
    xi = out["xi"]
    dc = _to_global(sc, _camber_local(sc, xi)).imag[..., :2] / _COMPLEX_STEP
    dr = _half_thickness(sc, xi)[0].imag / _COMPLEX_STEP
    u = _rotate(s, out["u"])
    normal = np.concatenate([blade.span * u, -((u * dc).sum(axis=-1) + dr)[..., None]], axis=-1)
    return normal / np.linalg.norm(normal, axis=-1, keepdims=True)


# ---------------------------------------------------------------------- validation
def _check_blade(blade: SampleBlade) -> None:
    """Reject parameters for which the disk-envelope construction breaks down."""
    def fail(what: str) -> None:
        raise BladeReconError(f"SampleBlade: {what}; change the parameters")

    if not blade.span > 0:
        fail(f"span must be > 0 mm, got {blade.span}")
    for name in ("camber_hub", "camber_tip"):
        if not 0 < getattr(blade, name) < 120:
            fail(f"{name} must be in (0, 120) degrees, got {getattr(blade, name)}")
    for name in ("le_radius_hub", "le_radius_tip", "te_radius_hub", "te_radius_tip"):
        if not getattr(blade, name) > 0:
            fail(f"{name} must be > 0 mm")
    if not 0.1 <= blade.tmax_position <= 0.9:
        fail(f"tmax_position must be in [0.1, 0.9], got {blade.tmax_position}")

    h = np.linspace(0.0, 1.0, 21)
    with np.errstate(invalid="ignore"):        # impossible values are reported just below
        s = _section(blade, h)
    if np.any(s.chord - s.r_le - s.r_te <= 0):
        fail("the chord must exceed r_LE + r_TE at every span height")
    if np.any(_half_thickness(s, blade.tmax_position)[0] <= np.maximum(s.r_le, s.r_te)):
        fail("the max thickness must exceed the LE and TE diameters")
    xi = np.linspace(0.0, 1.0, 201)
    r, dr, _ = _half_thickness(s.expand(), xi)
    if np.any(r <= 0):
        fail("the half thickness becomes <= 0 (thickness too small for the edge radii)")
    if not np.all(np.abs(dr / s.lcam[:, None]) < 0.95):
        fail("the thickness changes too fast along the camber line (|R'/L| >= 0.95)")
    if np.any(_half_thickness(s, blade.tmax_position)[2] >= 0):
        fail("the max thickness is not a maximum (t_max too small for the edge radii)")
    if np.any(s.theta / 2 + s.beta_le >= np.pi / 2) or np.any(s.theta / 2 - s.beta_te >= np.pi / 2):
        fail("the LE/TE point falls off its edge arc (camber too large)")
    for side in (-1.0, 1.0):
        f = _flank(s.expand(), xi, side)
        if np.any(f["speed"] <= 0.05 * s.lcam[:, None]) or np.any(f["curvature"] * r <= -0.9):
            fail("a flank folds over itself (thickness too large for the camber)")


# ---------------------------------------------------------------------- arc length
def _length_table(blade: SampleBlade, h: float, curvature_weight: float, intervals: int = 512):
    """Cumulative (weighted) arc length per piece at one span fraction h.

    The measure is ds * (1 + curvature_weight * sqrt(|kappa| * chord)); each interval is
    integrated by 8-node Gauss-Legendre of the exact speed. Returns per piece the nodes
    sigma, the cumulative measure at the nodes and the density d(measure)/dsigma there.
    """
    s = _section(blade, np.atleast_1d(np.asarray(h, dtype=float)))
    chord = float(s.chord[0])
    grid = np.linspace(0.0, 1.0, intervals + 1)
    gl = ((np.arange(intervals)[:, None] + _GL_X[None, :]) / intervals)

    def density(piece, sigma):
        g = _piece(s, piece, sigma)
        return g["speed"] * (1 + curvature_weight * np.sqrt(np.abs(g["curvature"]) * chord))

    table = []
    for k in range(_N_PIECES):
        steps = (density(k, gl) * _GL_W).sum(axis=1) / intervals
        table.append((grid, np.concatenate([[0.0], np.cumsum(steps)]), density(k, grid)))
    return s, table


def t_at_length_fraction(blade: SampleBlade, h: float, fractions,
                         curvature_weight: float = 0.0) -> np.ndarray:
    """Profile parameters t at the given fractions of the section's (weighted) arc length.

    ``fractions`` in [0, 1) (taken mod 1) are measured counter-clockwise from the LE point.
    With ``curvature_weight = a > 0`` the measure is arc length weighted by
    ``1 + a*sqrt(kappa*chord)`` (the 'plan' layout). Inversion per interval by cubic
    Hermite interpolation with the exact derivative 1/density: monotone, and the
    positions are of course exactly on the surface whatever the error in t.
    """
    s, table = _length_table(blade, h, curvature_weight)
    totals = np.array([tab[1][-1] for tab in table])
    starts = np.concatenate([[0.0], np.cumsum(totals)])
    target = np.mod(np.asarray(fractions, dtype=float), 1.0) * starts[-1]
    piece = np.clip(np.searchsorted(starts, target, side="right") - 1, 0, _N_PIECES - 1)
    t = np.empty_like(target)
    for k in range(_N_PIECES):
        mask = piece == k
        sig, cum, dens = table[k]
        q = target[mask] - starts[k]
        j = np.clip(np.searchsorted(cum, q, side="right") - 1, 0, sig.size - 2)
        ds = cum[j + 1] - cum[j]
        x = (q - cum[j]) / ds
        h00, h10 = (1 + 2 * x) * (1 - x) ** 2, x * (1 - x) ** 2
        h01, h11 = x * x * (3 - 2 * x), x * x * (x - 1)
        sigma = (h00 * sig[j] + h10 * ds / dens[j] + h01 * sig[j + 1] + h11 * ds / dens[j + 1])
        t[mask] = s.bounds[0, k] + s.widths[0, k] * np.clip(sigma, 0.0, 1.0)
    return np.mod(t, 1.0)


# ---------------------------------------------------------------------- samples
def section_heights(n_sections: int) -> np.ndarray:
    """Span fractions of ``n_sections`` equally spaced sections, hub (0) to tip (1)."""
    return np.linspace(0.0, 1.0, n_sections)


def sample_sections(blade: SampleBlade, n_sections: int = 6, n_points: int | None = None,
                    layout: str = "uniform", noise: float = 0.002, seed: int = 0,
                    scramble: bool = False, plan_weight: float = 1.0) -> list[np.ndarray]:
    """Measured-like sections: a list of (n, 3) arrays (mm), hub first.

    layout
        ``'uniform'``: ``n_points`` (default 2000) points equally spaced in arc length,
        starting at a random fraction of the perimeter (a scanner's line).
        ``'plan'``: a sparse measurement plan of ``n_points`` (default 65, ~97 % fewer
        points as in seed 000 §2.1) starting at the LE point, equally spaced in the
        measure ``ds * (1 + plan_weight*sqrt(kappa*chord))``: even along the flanks
        (kappa*chord ~ 1) and about 5x denser on the edge circles (kappa*chord ~ 60-115),
        so the LE/TE regions are never sparser than the flanks.
    noise
        sigma (mm) of isotropic Gaussian noise added to each coordinate (x, y and z).
    scramble
        shuffle the point order within each section (an unordered cloud).

    Points are in counter-clockwise order about +z unless scrambled. Reproducible for a
    given seed; the random draws do not depend on ``noise`` (noise=0 gives the same points
    without noise).
    """
    if layout not in ("uniform", "plan"):
        raise BladeReconError(
            f"sample_sections: layout must be 'uniform' or 'plan', got {layout!r}")
    if n_points is None:
        n_points = 2000 if layout == "uniform" else 65
    if n_sections < 2 or n_points < 3:
        raise BladeReconError("sample_sections: need at least 2 sections and 3 points per section")
    rng = np.random.default_rng(seed)
    sections = []
    for h in section_heights(n_sections):
        start = rng.random()
        if layout == "uniform":
            t = t_at_length_fraction(blade, h, (start + np.arange(n_points)) / n_points)
        else:
            t = t_at_length_fraction(blade, h, np.arange(n_points) / n_points, plan_weight)
        pts = blade.point(h, t) + noise * rng.standard_normal((n_points, 3))
        order = rng.permutation(n_points)
        sections.append(pts[order] if scramble else pts)
    return sections


def nominal_grid(blade: SampleBlade, n_span: int = 41, n_profile: int = 400) -> np.ndarray:
    """True points (n_profile, n_span, 3) mm: rows around the profile, columns along the span.

    Column j is the section at h = j/(n_span-1); row i is at the fraction i/n_profile of
    that section's arc length from the LE point (periodic: the first point is not
    repeated). Corresponding rows are smooth in h, so the grid suits dense interpolation
    (u periodic around, v clamped along the span) into a nominal surface.
    """
    heights = np.linspace(0.0, 1.0, n_span)
    frac = np.arange(n_profile) / n_profile
    return np.stack([blade.point(h, t_at_length_fraction(blade, h, frac)) for h in heights], axis=1)


def dense_truth(blade: SampleBlade, n_span: int = 41, n_profile: int = 400) -> np.ndarray:
    """(n_span*n_profile, 3) true points on and between the sections, hub section first.

    With the default 41 heights (step 0.025) every section of ``sample_sections`` with
    6 sections (step 0.2) is among them.
    """
    return nominal_grid(blade, n_span, n_profile).transpose(1, 0, 2).reshape(-1, 3)


def nominal_surface(blade: SampleBlade, n_span: int = 21, n_profile: int = 900,
                    curvature_weight: float = 1.5):
    """A B-spline surface through a dense grid of true points: the sample blade's nominal CAD.

    Rows are placed at equal fractions of curvature-weighted arc length (dense on the round
    edges, where the G1 joints of circle and flank need the points), interpolated periodic
    cubic around (common centripetal parameters averaged over the rows, seed 000 eq. 7) and
    clamped cubic along the span (eq. 8). Its distance from the true surface is measured in
    ``tests/test_sample_nominal.py`` (well under a micrometre).
    """
    from bladerecon.core.surface.skinning import interpolate_grid

    heights = np.linspace(0.0, 1.0, n_span)
    frac = np.arange(n_profile) / n_profile
    grid = np.stack([blade.point(h, t_at_length_fraction(blade, h, frac, curvature_weight))
                     for h in heights])                                       # (S, N, 3)
    return interpolate_grid(grid, "chord")
