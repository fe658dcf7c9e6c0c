"""Geometry of a spotlight collection: the one home of every k-space and range formula.

Frames and signs follow ``docs/conventions.md``: ground frame x east, y north, z up, scene centre at
the origin; pulse ``p`` looks along ``u_p = (cos φ cos θ, cos φ sin θ, -sin φ)`` from its antenna
phase centre ``a_p`` to the scene centre. Every other module (simulator, image formers,
regularisers, PSF) takes its wavenumbers, k-space coordinates, ranges and sampling limits from
here instead of re-deriving them.

All functions are array in, array out, float64, and vectorised over pulses (axis 0) and
frequencies (axis 1).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "C",
    "wavenumbers",
    "look_directions",
    "kspace_coordinates",
    "dimensionless_frequencies",
    "alias_free_radii",
    "resolutions",
    "image_sampling",
    "frequency_spacing",
    "azimuth_spacing",
    "antenna_positions_circle",
    "antenna_positions_line",
    "angles_from_positions",
    "differential_range",
    "bistatic_differential_range",
    "bistatic_reference_range",
    "farfield_phase_error",
    "signal_phase",
    "image_plane_position",
]

#: Speed of light in vacuum (m/s).
C = 299_792_458.0


def _as_pm(freq_hz, n_pulses: int) -> np.ndarray:
    """Frequencies as a [P, M] float64 array (broadcast a shared [M] vector)."""
    f = np.asarray(freq_hz, dtype=np.float64)
    if f.ndim == 1:
        return np.broadcast_to(f, (n_pulses, f.size))
    return f


def wavenumbers(freq_hz, elevation_rad) -> np.ndarray:
    """Ground-plane wavenumbers ``k = 4π α cos φ / c`` (paper eq. ``k-values``), in rad/m.

    Parameters
    ----------
    freq_hz : array_like, shape (M,) or (P, M)
        Frequencies α_j (Hz), shared by all pulses or per pulse.
    elevation_rad : array_like, shape (P,) or scalar
        Elevation φ_p of each pulse.

    Returns
    -------
    k : ndarray, shape (P, M)
    """
    el = np.atleast_1d(np.asarray(elevation_rad, dtype=np.float64))
    f = _as_pm(freq_hz, el.size)
    return 4.0 * np.pi * f * np.cos(el)[:, None] / C


def look_directions(azimuth_rad, elevation_rad) -> np.ndarray:
    """Unit look vectors ``u_p`` from antenna to scene centre, shape (P, 3)."""
    az = np.atleast_1d(np.asarray(azimuth_rad, dtype=np.float64))
    el = np.broadcast_to(np.asarray(elevation_rad, dtype=np.float64), az.shape)
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), -np.sin(el)], axis=-1)


def kspace_coordinates(freq_hz, azimuth_rad, elevation_rad):
    """Physical k-space sample coordinates ``k ξ_θ`` (rad/m), paper eq. ``eq1``.

    Returns
    -------
    kx, ky : ndarray, shape (P, M)
    """
    az = np.atleast_1d(np.asarray(azimuth_rad, dtype=np.float64))
    el = np.broadcast_to(np.asarray(elevation_rad, dtype=np.float64), az.shape)
    k = wavenumbers(freq_hz, el)
    return k * np.cos(az)[:, None], k * np.sin(az)[:, None]


def wrap_phase(t):
    """Wrap phases or dimensionless frequencies into [-π, π): ``t - 2π floor((t + π) / 2π)``.

    The pixel lattice sees frequencies modulo 2π (section ``sec: alias``), so on it the wrap is
    exact. Works on arrays and scalars: the one home of the lattice wrap.

    Examples
    --------
    >>> float(wrap_phase(3 * np.pi / 2)) == -np.pi / 2
    True
    """
    return t - 2.0 * np.pi * np.floor((t + np.pi) / (2.0 * np.pi))


def dimensionless_frequencies(freq_hz, azimuth_rad, elevation_rad, pixel_m, *, wrap: bool = True):
    """Dimensionless frequencies ``(k1, k2) = k h ξ_θ`` of the pixel model (eq. ``fund-freq``).

    Parameters
    ----------
    pixel_m : float or (float, float)
        Pixel length h (or (hx, hy) for a rectangular pixel).
    wrap : bool
        Wrap into [-π, π), which is exact on the pixel grid (section ``sec: alias``).

    Returns
    -------
    k1, k2 : ndarray, shape (P, M)
        Multiply ``x``-index by k1 and ``y``-index by k2.
    """
    hx, hy = (pixel_m, pixel_m) if np.isscalar(pixel_m) else pixel_m
    kx, ky = kspace_coordinates(freq_hz, azimuth_rad, elevation_rad)
    k1, k2 = kx * hx, ky * hy
    if wrap:
        k1 = wrap_phase(k1)
        k2 = wrap_phase(k2)
    return k1, k2


def frequency_spacing(freq_hz) -> float:
    """Largest spacing Δα between adjacent frequencies (Hz); 0 for a single frequency."""
    f = np.asarray(freq_hz, dtype=np.float64)
    f = f if f.ndim == 1 else f[0]
    if f.size < 2:
        return 0.0
    return float(np.max(np.abs(np.diff(np.sort(f)))))


def _covered_gaps(azimuth_rad):
    """Gaps between adjacent looks around the circle, without the uncovered arc (if any)."""
    az = np.sort(np.mod(np.asarray(azimuth_rad, dtype=np.float64), 2 * np.pi))
    gaps = np.append(np.diff(az), az[0] + 2 * np.pi - az[-1])
    i = int(np.argmax(gaps))
    if gaps[i] > 1.5 * np.median(gaps) + 1e-12:  # the part of the circle no pulse looks from
        return np.delete(gaps, i), True
    return gaps, False


def azimuth_spacing(azimuth_rad) -> float:
    """Largest spacing Δθ between adjacent look azimuths (rad), wrap-aware; 0 for one pulse."""
    if np.size(azimuth_rad) < 2:
        return 0.0
    gaps, _ = _covered_gaps(azimuth_rad)
    return float(np.max(gaps))


def alias_free_radii(freq_hz, azimuth_rad, elevation_rad):
    """Alias-free scene radii from the sampling (section ``sec: size``, eq. ``scene-size``).

    ``R = c / (4 Δα cos φ)`` in range and ``R_cr = c / (4 α_M cos φ Δθ)`` in cross-range, with
    the largest spacings and, for varying elevation, the largest ``cos φ`` (the tightest limit).

    Returns
    -------
    r_range, r_cross : float
        Radii in metres; ``inf`` where a dimension has a single sample.
    """
    cos_el = float(np.max(np.cos(np.atleast_1d(elevation_rad))))
    dalpha = frequency_spacing(freq_hz)
    dtheta = azimuth_spacing(azimuth_rad)
    alpha_max = float(np.max(freq_hz))
    r_range = np.inf if dalpha == 0 else C / (4.0 * dalpha * cos_el)
    r_cross = np.inf if dtheta == 0 else C / (4.0 * alpha_max * cos_el * dtheta)
    return r_range, r_cross


def resolutions(freq_hz, azimuth_rad, elevation_rad):
    """Range and cross-range resolution (m), docs/conventions.md "Sampling limits".

    ``ρ_r = c / (2 B cos φ)`` with ``B = α_M - α_1`` and ``ρ_cr = c / (4 α_c cos φ sin(Θ/2))``
    for a total aperture Θ; ``inf`` for a single frequency or a single pulse. Θ is capped at π
    (a wider aperture does not sharpen further in this formula).
    """
    f = np.asarray(freq_hz, dtype=np.float64)
    cos_el = float(np.mean(np.cos(np.atleast_1d(elevation_rad))))
    bandwidth = float(np.max(f) - np.min(f))
    alpha_c = 0.5 * float(np.max(f) + np.min(f))
    az = np.atleast_1d(np.asarray(azimuth_rad, dtype=np.float64))
    aperture = total_aperture(az)
    rho_r = np.inf if bandwidth == 0 else C / (2.0 * bandwidth * cos_el)
    rho_cr = np.inf if aperture == 0 else C / (4.0 * alpha_c * cos_el * np.sin(min(aperture, np.pi) / 2))
    return rho_r, rho_cr


#: What :func:`resolutions` computes, in words (``sar info`` prints it beside the numbers).
RESOLUTION_DEFINITION = ("range c/(2 B cos(elevation)), cross-range c/(4 f_c cos(elevation) sin(aperture/2)): "
                         "the distance from the peak to the first null of an unwindowed cut")


def image_sampling(freq_hz, azimuth_rad, elevation_rad):
    """Largest pixel spacings ``(dx, dy)`` (m) that sample the image without aliasing its band:
    ``2π / (max k_x - min k_x)`` and likewise in y, over the k-space samples
    (:func:`kspace_coordinates`); ``inf`` where the band has no extent.

    A grid coarser than this lets a bright point fall between pixels: its energy on the grid
    depends on where it lies, and on such a grid a search over the phase can move points onto
    pixels (minimum-entropy autofocus does; ``docs/autofocus.md``).
    """
    kx, ky = kspace_coordinates(freq_hz, azimuth_rad, elevation_rad)
    ex, ey = float(np.ptp(kx)), float(np.ptp(ky))
    return (np.inf if ex == 0 else 2.0 * np.pi / ex), (np.inf if ey == 0 else 2.0 * np.pi / ey)


def total_aperture(azimuth_rad) -> float:
    """Total azimuth extent Θ (rad) spanned by the looks, wrap-aware (2π for a full circle)."""
    if np.size(azimuth_rad) < 2:
        return 0.0
    gaps, open_arc = _covered_gaps(azimuth_rad)
    return float(np.sum(gaps)) if open_arc else 2 * np.pi


def antenna_positions_circle(azimuth_rad, elevation_rad, range_m) -> np.ndarray:
    """Antenna positions ``a_p = -r0 u_p`` on a circular (constant range) path, shape (P, 3)."""
    u = look_directions(azimuth_rad, elevation_rad)
    r0 = np.broadcast_to(np.asarray(range_m, dtype=np.float64), (u.shape[0],))
    return -r0[:, None] * u


def antenna_positions_line(azimuth_rad, elevation_rad, range_m, center_azimuth_rad) -> np.ndarray:
    """Antenna positions on a straight, level flight line, shape (P, 3).

    The line is horizontal at the altitude ``r0 sin φ``, perpendicular to the look at
    ``center_azimuth_rad``, at ground distance ``r0 cos φ`` from the scene centre; pulse p sits
    where the horizontal look azimuth equals ``azimuth_rad[p]`` (so its elevation and range vary
    along the line; use :func:`angles_from_positions` for the exact per-pulse angles).
    """
    az = np.atleast_1d(np.asarray(azimuth_rad, dtype=np.float64))
    ground = float(range_m) * np.cos(float(elevation_rad))
    height = float(range_m) * np.sin(float(elevation_rad))
    rel = az - center_azimuth_rad
    if np.any(np.abs(np.cos(rel)) < 1e-6):
        raise ValueError("a straight flight line cannot see the scene at ±90° from its centre look")
    along = ground * np.tan(rel)
    # antenna horizontal position = -ground * xi_c + along * t, t = xi_c rotated +90°
    xi_c = np.array([np.cos(center_azimuth_rad), np.sin(center_azimuth_rad)])
    t = np.array([-xi_c[1], xi_c[0]])
    # looking from the antenna towards the centre at azimuth θ means the antenna lies at -θ side:
    # horizontal antenna position a_h = -ρ ξ_θ, so a_h·t = -ρ sin(θ-θc) < 0 for θ > θc.
    xy = -ground * xi_c[None, :] - along[:, None] * t[None, :]
    return np.column_stack([xy, np.full(az.size, height)])


def angles_from_positions(antenna_position_m):
    """Look azimuth θ_p and elevation φ_p (rad) from antenna positions (scene centre at origin).

    Returns
    -------
    azimuth_rad, elevation_rad, range_to_center_m : ndarray, shape (P,)
    """
    a = np.asarray(antenna_position_m, dtype=np.float64)
    r0 = np.linalg.norm(a, axis=1)
    u = -a / r0[:, None]
    az = np.arctan2(u[:, 1], u[:, 0])
    el = np.arcsin(np.clip(-u[:, 2], -1.0, 1.0))
    return az, el, r0


def differential_range(antenna_position_m, range_to_center_m, points_m) -> np.ndarray:
    """Differential range ``|a_p - x| - r0_p`` (m) in a cancellation-free form.

    ``|a - x| - |a| = (|x|² - 2 a·x) / (|a - x| + |a|)`` loses no digits even at r0 = 100 km,
    unlike the naive difference of two large numbers; a reference range r0_p other than |a_p|
    (motion-compensated data) adds ``|a_p| - r0_p``.

    Parameters
    ----------
    antenna_position_m : array_like, shape (P, 3)
    range_to_center_m : array_like, shape (P,)
    points_m : array_like, shape (..., 3) or (..., 2)
        Scene points; a missing z is 0.

    Returns
    -------
    dr : ndarray, shape (P, ...)
    """
    a = np.asarray(antenna_position_m, dtype=np.float64)
    r0 = np.asarray(range_to_center_m, dtype=np.float64)
    x, pts = _points3(points_m)
    # |a_p| - r0_p is tiny (0 unless motion-compensated) but |a_p| rounds by ~1e-12 m at 10 km:
    # take that difference in extended precision so the model's r0_p is honoured exactly.
    norm_ld = np.sqrt(np.sum(a.astype(np.longdouble) ** 2, axis=1))
    offset = (norm_ld - r0.astype(np.longdouble)).astype(np.float64)
    dr = _relative_range(a, pts) + offset[:, None]
    return dr.reshape((a.shape[0],) + x.shape[:-1])


def _points3(points_m):
    """Points as (..., 3) (a missing z is 0) and as a flat (S, 3) view."""
    x = np.asarray(points_m, dtype=np.float64)
    if x.shape[-1] == 2:
        x = np.concatenate([x, np.zeros(x.shape[:-1] + (1,))], axis=-1)
    return x, x.reshape(-1, 3)


def _relative_range(a, pts):
    """``|a_p - x| - |a_p|`` (P, S) as ``(|x|² - 2 a·x) / (|a - x| + |a|)`` (no cancellation)."""
    norm_a = np.linalg.norm(a, axis=1)
    ax = a @ pts.T  # (P, S)
    xx = np.einsum("ij,ij->i", pts, pts)[None, :]
    dist = np.sqrt(np.maximum(norm_a[:, None] ** 2 - 2 * ax + xx, 0.0))
    return (xx - 2 * ax) / (dist + norm_a[:, None])


def bistatic_differential_range(transmit_position_m, receive_position_m, range_to_center_m,
                                points_m) -> np.ndarray:
    """Half the two-way path minus the reference: ``(|t_p - x| + |q_p - x|)/2 - r0_p`` (m).

    docs/conventions.md "Spherical with separate transmit and receive positions": the platform moves
    while the echo travels (or transmitter and receiver are different platforms, a bistatic
    collection). Each one-way term is taken cancellation-free as in :func:`differential_range`
    and the constant ``(|t_p| + |q_p|)/2 - r0_p`` in extended precision. When ``t = q`` this is
    *exactly* :func:`differential_range` (the same code path, bit for bit).

    Parameters
    ----------
    transmit_position_m, receive_position_m : array_like, shape (P, 3)
    range_to_center_m : array_like, shape (P,)
        ``r0_p``, normally ``(|t_p - s| + |q_p - s|)/2`` for the scene centre s (the origin).
    points_m : array_like, shape (..., 3) or (..., 2)

    Returns
    -------
    dr : ndarray, shape (P, ...)
    """
    t = np.asarray(transmit_position_m, dtype=np.float64)
    q = np.asarray(receive_position_m, dtype=np.float64)
    if t is q or np.array_equal(t, q):
        return differential_range(t, range_to_center_m, points_m)
    r0 = np.asarray(range_to_center_m, dtype=np.float64)
    x, pts = _points3(points_m)
    nt = np.sqrt(np.sum(t.astype(np.longdouble) ** 2, axis=1))
    nq = np.sqrt(np.sum(q.astype(np.longdouble) ** 2, axis=1))
    offset = (0.5 * (nt + nq) - r0.astype(np.longdouble)).astype(np.float64)
    dr = 0.5 * (_relative_range(t, pts) + _relative_range(q, pts)) + offset[:, None]
    return dr.reshape((t.shape[0],) + x.shape[:-1])


def bistatic_reference_range(transmit_position_m, receive_position_m, center_m=(0.0, 0.0, 0.0)):
    """``r0_p = (|t_p - s| + |q_p - s|)/2`` (m): half the two-way path to the scene centre s."""
    t = np.asarray(transmit_position_m, dtype=np.float64)
    q = np.asarray(receive_position_m, dtype=np.float64)
    s = np.asarray(center_m, dtype=np.float64)
    return 0.5 * (np.linalg.norm(t - s, axis=1) + np.linalg.norm(q - s, axis=1))


#: Far-field phase error (rad) at the grid corner above which a far-field method (or operator) on
#: spherical data is warned about, and `sar info` says so: the one threshold every caller uses.
DEFOCUS_WARN_RAD = 0.1


def farfield_phase_error(range_to_center_m, freq_max_hz, radius_m) -> float:
    """Predicted far-field phase error at distance ``radius_m`` from the centre (rad).

    ``(4π α_max / c) |x|² / (2 r0)`` (docs/conventions.md "Data models"): what a far-field method
    loses on spherical data; a few tenths of a radian already defocus.
    """
    r0 = float(np.min(range_to_center_m))
    return 4.0 * np.pi * float(freq_max_hz) / C * float(radius_m) ** 2 / (2.0 * r0)


def signal_phase(freq_hz, azimuth_rad, elevation_rad, points_m, *, model="farfield",
                 antenna_position_m=None, range_to_center_m=None,
                 receive_position_m=None) -> np.ndarray:
    """Phase ψ[p, j, s] with ``d[p, j] = Σ_s a_s exp(-i ψ)`` for point scatterers (float64).

    Far-field: ``ψ = k_pj ξ_θp · x_s`` (eq. ``eq1``). Spherical: ``ψ = (4π α_pj / c)(|a_p - x_s| - r0_p)``;
    with ``receive_position_m`` given, ``antenna_position_m`` is the transmit position and the range
    is :func:`bistatic_differential_range`.
    The matched filter multiplies by ``exp(+i ψ)``. Memory is P × M × S: chunk the callers.

    Returns
    -------
    psi : ndarray, shape (P, M, S)
    """
    x = np.atleast_2d(np.asarray(points_m, dtype=np.float64))
    az = np.atleast_1d(np.asarray(azimuth_rad, dtype=np.float64))
    if model == "farfield":
        kx, ky = kspace_coordinates(freq_hz, az, elevation_rad)
        return kx[:, :, None] * x[None, None, :, 0] + ky[:, :, None] * x[None, None, :, 1]
    if model == "spherical":
        if antenna_position_m is None or range_to_center_m is None:
            raise ValueError("the spherical model needs antenna positions and ranges")
        if receive_position_m is None:
            dr = differential_range(antenna_position_m, range_to_center_m, x)  # (P, S)
        else:
            dr = bistatic_differential_range(antenna_position_m, receive_position_m, range_to_center_m, x)
        f = _as_pm(freq_hz, az.size)
        return (4.0 * np.pi / C) * f[:, :, None] * dr[:, None, :]
    raise ValueError(f"unknown model {model!r}; expected 'farfield' or 'spherical'")


def image_plane_position(points_m, *, model="farfield", antenna_position_m=None, range_to_center_m=None,
                         receive_position_m=None, iterations=6) -> np.ndarray:
    """Where point scatterers focus in the image plane z = 0 (their layover), shape (S, 2).

    A point off the plane (z ≠ 0) focuses at the ground point ``g`` whose range history matches
    its own: the spread of ``δ_p(g) = R_p(g) - R_p(x_s)`` over the pulses is least (its phase
    ``k_c δ_p`` must be constant for the pulses to add up, which fixes cross-range) and its mean is
    zero (range). ``R_p`` is :func:`differential_range` (or :func:`bistatic_differential_range`
    with ``receive_position_m``), solved by Gauss-Newton from ``(x_s, y_s)``. For a short aperture
    this is the textbook layover: ``z tan φ`` toward the radar along the ground range. The
    far-field model (eq. ``eq1``, :func:`signal_phase`) holds no height term, so there a point
    focuses at its own ``(x, y)``.

    Parameters
    ----------
    points_m : array_like, shape (S, 3) or (S, 2)
    model : {'farfield', 'spherical'}
    antenna_position_m, range_to_center_m, receive_position_m : array_like, optional
        As in :func:`signal_phase` (needed for the spherical model).
    iterations : int
        Gauss-Newton steps (the problem is nearly linear: two or three reach 1e-9 m).

    Returns
    -------
    ndarray, shape (S, 2)
        Focus positions (x, y) in metres.
    """
    x, pts = _points3(np.atleast_2d(points_m))
    g = pts[:, :2].copy()
    if model == "farfield" or not np.any(pts[:, 2]):
        return g
    if antenna_position_m is None or range_to_center_m is None:
        raise ValueError("the spherical model needs antenna positions and ranges")
    t = np.asarray(antenna_position_m, dtype=np.float64)
    q = t if receive_position_m is None else np.asarray(receive_position_m, dtype=np.float64)

    def ranges(p3):
        return bistatic_differential_range(t, q, range_to_center_m, p3)  # (P, S)

    target = ranges(pts)
    for _ in range(int(iterations)):
        g3 = np.concatenate([g, np.zeros((g.shape[0], 1))], axis=1)
        d = ranges(g3) - target  # (P, S)
        ut = g3[None, :, :] - t[:, None, :]
        uq = g3[None, :, :] - q[:, None, :]
        jac = 0.5 * (ut / np.linalg.norm(ut, axis=2, keepdims=True)
                     + uq / np.linalg.norm(uq, axis=2, keepdims=True))[:, :, :2]  # (P, S, 2)
        for s in range(g.shape[0]):
            jm, dm = jac[:, s].mean(axis=0), d[:, s].mean()
            # rows: the pulses' deviations from their mean (spread), then the mean, weighted far above
            w = 1e3 * np.sqrt(d.shape[0])
            a = np.vstack([jac[:, s] - jm, w * jm])
            b = -np.concatenate([d[:, s] - dm, [w * dm]])
            g[s] += np.linalg.lstsq(a, b, rcond=None)[0]
    return g
