"""What a CPHD file's metadata may get wrong, and how sarcli finds out: vendor quirks, the phase
sign checked against the data, the troposphere.

Vendor quirks (recognised from ``CollectionID/CollectorName``, ``ProductInfo/Profile`` and
``ProductInfo/CreationInfo/Application``; each applied one is said in one line):

* Capella: the files declare ``SGN = +1`` while their data follow -1.
* ICEYE: ``TDTropoSRP = 0`` while the troposphere's delay is in the data, so an image formed as
  the file says lies about 6 m in ground range from ICEYE's own (corrected) products; the delay
  of :func:`troposphere_delay` is removed.

The sign check (:func:`sign_from_swath`): a collection imaged with the wrong sign still focuses,
as the mirror image of the scene through the SRP, so imaging both ways cannot decide. The saved
TOA swath can: range-compressed with the right sign, a vector's energy lies in
``[TOA1, TOA2]``; with the wrong one, in ``[-TOA2, -TOA1]``. Where the two differ (an asymmetric
swath), the energy in each one's own part decides.

Troposphere: in the CPHD signal model a vector is referenced to the SRP's time of arrival
*including* ``TDTropoSRP``, so a file whose ``TDTropoSRP`` is the true delay needs nothing; one
whose value is short leaves the difference ``δ`` in the data, which shifts the image by
``c δ / 2`` in slant range, and ``δ`` is removed (:mod:`.signal`, step 4).
"""

from __future__ import annotations

import numpy as np

from ...core import geometry

__all__ = ["VENDOR_QUIRKS", "vendor_of", "troposphere_delay", "tropo_n0", "sign_from_swath", "swath_can_tell",
           "DEFAULT_N0", "TROPO_SCALE_HEIGHT_M", "SIGN_DECISIVE_RATIO", "TROPOSPHERE_MODES"]

#: ``troposphere`` choices of the reader: auto (the file, or a vendor quirk), file (the file only),
#: model.
TROPOSPHERE_MODES = ("auto", "file", "model")

#: Global mean surface refractivity and its scale height (ITU-R P.453, exponential model
#: ``N(h) = N0 exp(-h / H0)``), used when the file gives no ``TropoParameters/N0``.
DEFAULT_N0 = 315.0
TROPO_SCALE_HEIGHT_M = 7350.0
#: Energy ratio between the swath's and its mirror's own parts that decides the sign.
SIGN_DECISIVE_RATIO = 10.0
#: Each of the swath's and its mirror's own parts must cover this fraction of the unambiguous
#: TOA period for the check to speak.
_MIN_OWN_FRACTION = 0.05

#: vendor -> (what its files get wrong, what sarcli does)
VENDOR_QUIRKS = {
    "capella": {"name": "Capella", "sgn": -1, "why": "its files declare SGN = +1 while the data follow -1"},
    "iceye": {"name": "ICEYE", "troposphere": "model",
              "why": "TDTropoSRP is 0 while the troposphere's delay is in the data"},
}


def vendor_of(xml) -> tuple[str | None, str]:
    """The vendor of :data:`VENDOR_QUIRKS` named in the file's own metadata, and where.

    Returns
    -------
    (str or None, str)
        The vendor key (None when none is recognised) and ``"Field 'value'"`` naming the evidence.
    """
    for path in ("{*}CollectionID/{*}CollectorName", "{*}ProductInfo/{*}Profile",
                 "{*}ProductInfo/{*}CreationInfo/{*}Application"):
        for node in xml.findall(path):
            text = (node.text or "").strip()
            for name in VENDOR_QUIRKS:
                if name in text.lower():
                    return name, f"{path.rsplit('}', 1)[-1]} '{text}'"
    return None, ""


def tropo_n0(xml) -> tuple[float, str]:
    """Surface refractivity at height 0 from ``Global/TropoParameters`` (else :data:`DEFAULT_N0`).

    ``RefHeight = IARP`` gives N0 at the IARP's height; it is carried to height 0 with the
    exponential model.
    """
    n0 = xml.findtext("{*}Global/{*}TropoParameters/{*}N0")
    if n0 is None:
        return DEFAULT_N0, f"the global mean N0 = {DEFAULT_N0:g}"
    value = float(n0)
    if (xml.findtext("{*}Global/{*}TropoParameters/{*}RefHeight") or "ZERO").strip() == "IARP":
        hae = float(xml.findtext("{*}SceneCoordinates/{*}IARP/{*}LLH/{*}HAE") or 0.0)
        value *= np.exp(hae / TROPO_SCALE_HEIGHT_M)
    return value, f"the file's TropoParameters N0 = {float(n0):g}"


def troposphere_delay(srp_ecf, tx_ecf, rcv_ecf, n0: float) -> np.ndarray:
    """Two-way troposphere delay (s) at the SRP of every vector.

    One way, the excess path of the exponential refractivity model above the SRP, mapped to the
    slant by the grazing angle ``ψ`` (flat layers)::

        ΔR = 1e-6 N0 H0 exp(-h / H0) / sin ψ

    with ``h`` the SRP's height above the ellipsoid and ``H0`` :data:`TROPO_SCALE_HEIGHT_M`; the
    delay is ``(ΔR_tx + ΔR_rcv) / c``. (N0 = 315, ψ = 64°: 2.58 m one way, 17.2 ns; the flat
    mapping overstates it below ~10° of grazing.)

    Parameters
    ----------
    srp_ecf, tx_ecf, rcv_ecf : array [P, 3]
        ECF positions (m).
    n0 : float
        Refractivity at height 0.
    """
    from sarkit import wgs84

    srp = np.asarray(srp_ecf, np.float64)
    llh = wgs84.cartesian_to_geodetic(srp)
    up = wgs84.up(llh)
    zenith = 1e-6 * n0 * TROPO_SCALE_HEIGHT_M * np.exp(-llh[..., 2] / TROPO_SCALE_HEIGHT_M)
    total = np.zeros(srp.shape[:-1])
    for apc in (np.asarray(tx_ecf, np.float64), np.asarray(rcv_ecf, np.float64)):
        los = apc - srp
        sin_graze = np.einsum("...i,...i->...", los, up) / np.linalg.norm(los, axis=-1)
        total = total + zenith / np.maximum(sin_graze, 1e-3)
    return total / geometry.C


def sign_from_swath(rows: np.ndarray, fx_step_hz, toa1_s, toa2_s) -> tuple[int, float, float]:
    """Does the energy of range-compressed FX rows lie in the saved swath or in its mirror?

    Each row ``d_k`` (read with the declared sign, so in sarcli's ``SGN = -1`` form) is
    range-compressed with a Hann window, ``r(τ) = Σ_k w_k d_k exp(+i 2π k Δf τ)``, on a grid four
    times finer than ``1 / (M Δf)`` over one unambiguous period ``T = 1/Δf``. ``A`` is the swath
    ``[TOA1, TOA2]`` and ``B`` its mirror ``[-TOA2, -TOA1]``, both modulo ``T``.

    Parameters
    ----------
    rows : array [n, M] complex
    fx_step_hz, toa1_s, toa2_s : array [n]
        ``SCSS`` (FX spacing), ``TOA1``, ``TOA2`` of each row.

    Returns
    -------
    (int, float, float)
        +1 when the energy in ``A \\ B`` exceeds that in ``B \\ A`` by :data:`SIGN_DECISIVE_RATIO`
        (the declared sign holds), -1 when the reverse holds (the data follow the other sign), 0
        when the data cannot tell (a nearly symmetric swath, or no clear winner); then the
        fractions of the energy in ``A \\ B`` and ``B \\ A``.
    """
    rows = np.asarray(rows, np.complex128)
    n, M = rows.shape
    L = 4 * (1 << int(np.ceil(np.log2(max(M, 2)))))
    w = np.hanning(M + 2)[1:-1]
    power = np.abs(np.fft.ifft(rows * w, n=L, axis=1)) ** 2  # r(τ_m), τ_m = m T / L
    e_own = e_mirror = 0.0
    for i in range(n):
        in_a, in_b = _swath_masks(L, fx_step_hz[i], toa1_s[i], toa2_s[i])
        e_own += float(power[i][in_a & ~in_b].sum())
        e_mirror += float(power[i][in_b & ~in_a].sum())
    total = float(power.sum()) or 1.0
    f_own, f_mirror = e_own / total, e_mirror / total
    if not swath_can_tell(fx_step_hz, toa1_s, toa2_s):
        return 0, f_own, f_mirror
    if e_own > SIGN_DECISIVE_RATIO * e_mirror:
        return 1, f_own, f_mirror
    if e_mirror > SIGN_DECISIVE_RATIO * e_own:
        return -1, f_own, f_mirror
    return 0, f_own, f_mirror


def _swath_masks(L: int, fx_step, toa1, toa2):
    """Which of ``L`` TOA samples over one period ``1/fx_step`` lie in the swath ``A`` and in its mirror ``B``."""
    period = 1.0 / float(fx_step)
    tau = np.arange(L) * period / L
    width = float(toa2 - toa1)
    return np.mod(tau - toa1, period) <= width, np.mod(tau + toa2, period) <= width


def swath_can_tell(fx_step_hz, toa1_s, toa2_s, L: int = 1024) -> bool:
    """Whether the saved swath ``A`` and its mirror ``B`` each have a part of their own covering
    at least 5 % of the unambiguous period, on average over the vectors (from the PVPs alone,
    before any sample is read)."""
    own = mirror = 0.0
    for step, t1, t2 in zip(np.atleast_1d(fx_step_hz), np.atleast_1d(toa1_s), np.atleast_1d(toa2_s)):
        in_a, in_b = _swath_masks(L, step, t1, t2)
        own += float(np.mean(in_a & ~in_b))
        mirror += float(np.mean(in_b & ~in_a))
    count = max(np.atleast_1d(fx_step_hz).size, 1)
    return min(own, mirror) / count >= _MIN_OWN_FRACTION
