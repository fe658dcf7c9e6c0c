"""The aperture reference point of a collection as SICD and SIDD write it (``Position/ARPPoly``,
``Measurement/ARPPoly``): pulse times and a polynomial in them."""

from __future__ import annotations

import numpy as np

from ..core.acquisition import Acquisition
from ..errors import SarcliInputError
from .georef import enu_to_ecf

__all__ = ["arp_polynomial"]


def _pulse_times(acq: Acquisition):
    """Pulse times (s from the collection start) and ARP positions (local ENU).

    A collection read from CPHD keeps its own transmit and receive times
    (``acq.extra['tx_time_s']``, ``['rcv_time_s']``): then the aperture reference point of a
    pulse is the midpoint of its transmit and receive positions at the mid time (SICD's ARP for
    a monostatic collection). Other collections are timed synthetically as in :mod:`.cphd`.
    """
    from .cphd import pulse_times

    extra = acq.extra or {}
    pos = np.asarray(acq.antenna_position_m, np.float64)
    tx_t, rcv_t = extra.get("tx_time_s"), extra.get("rcv_time_s")
    if tx_t is not None and rcv_t is not None and len(tx_t) == pos.shape[0]:
        return 0.5 * (np.asarray(tx_t, np.float64) + np.asarray(rcv_t, np.float64)), pos, True
    return pulse_times(pos)[0], pos, False


def arp_polynomial(acq: Acquisition, ref):
    """The aperture reference point as SICD writes it (``Position/ARPPoly``) and the COA time.

    Parameters
    ----------
    acq : Acquisition
        With antenna positions.
    ref : ReferencePoint
        Where the local frame sits on the Earth.

    Returns
    -------
    t : ndarray (P,)
        Pulse times (s from the collection start), see :func:`_pulse_times`.
    coefs : ndarray (3, order + 1)
        ECF X, Y, Z polynomial coefficients in t (increasing powers), order ``min(5, P - 1)``,
        fitted by least squares about the mid time.
    t_coa : float
        The centre-of-aperture time (the middle of the collection, ``Grid/TimeCOAPoly``).
    true_times : bool
        Whether the times are the collection's own (CPHD) or synthetic.
    """
    t, pos, true_times = _pulse_times(acq)
    P = pos.shape[0]
    if P < 2:
        raise SarcliInputError("SICD export needs a collection of at least two pulses")
    pos_ecf = enu_to_ecf(pos, ref)
    order = int(min(5, P - 1))
    t_mid = 0.5 * float(t[0] + t[-1])  # fit about the middle (conditioning), then shift back
    arp = [np.polynomial.Polynomial.fit(t - t_mid, pos_ecf[:, axis], order).convert() for axis in range(3)]
    shift = np.polynomial.Polynomial([-t_mid, 1.0])
    arp = [a(shift).coef for a in arp]
    coefs = np.stack([np.pad(c, (0, order + 1 - c.size)) for c in arp])
    return t, coefs, t_mid, true_times
