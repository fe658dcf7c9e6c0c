"""Parts of the CPHD reader (:mod:`sarcli.io.cphd`): block-wise signal reading and the image grid."""

from __future__ import annotations

import warnings

import numpy as np

from ..core.grid import Grid
from .georef import GeometryWarning, ReferencePoint, enu_basis

__all__ = ["READ_BLOCK", "AXES_TOLERANCE_RAD", "read_signal_blocks", "grid_from_xml"]

#: Pulses read from the signal array at a time (bounds the temporary of integer formats).
READ_BLOCK = 1024
#: Angle (rad) between the file's image-area axes (uIAX, uIAY) and local East/North above which
#: its ImageGrid cannot be used as our east/north-aligned grid (a GeometryWarning says so).
AXES_TOLERANCE_RAD = 1e-6


def read_signal_blocks(reader, channel: str, pvp) -> np.ndarray:
    """The channel's signal as complex64 [P, M], read in blocks of :data:`READ_BLOCK` vectors.

    Integer I/Q formats are converted block by block (no full-size integer temporary); an
    ``AmpSF`` PVP scales each vector (CPHD: multiply).
    """
    xml = reader.metadata.xmltree
    node = xml.find(f"{{*}}Data/{{*}}Channel[{{*}}Identifier='{channel}']")
    n_vec = int(node.findtext("{*}NumVectors"))
    n_smp = int(node.findtext("{*}NumSamples"))
    out = np.empty((n_vec, n_smp), dtype=np.complex64)
    amp = pvp["AmpSF"] if "AmpSF" in pvp.dtype.names else None
    for start in range(0, n_vec, READ_BLOCK):
        stop = min(start + READ_BLOCK, n_vec)
        blk = np.asarray(reader.read_signal(channel, start_vector=start, stop_vector=stop))
        if blk.dtype.names:  # integer I/Q formats
            names = blk.dtype.names
            blk = blk[names[0]].astype(np.float32) + 1j * blk[names[1]].astype(np.float32)
        blk = blk.astype(np.complex64)
        if amp is not None:
            blk = blk * amp[start:stop, None]
        out[start:stop] = blk
    return out


def grid_from_xml(xml, ref: ReferencePoint) -> Grid | None:
    """Our grid from ``SceneCoordinates/ImageGrid`` when its axes are local East and North.

    Our frame is east-north-up at the IARP (CONVENTIONS.md). A planar image area whose
    uIAX/uIAY are East/North (to :data:`AXES_TOLERANCE_RAD`) gives the grid exactly; other axes
    (a rotated or tilted image plane, or a HAE surface) cannot be an east/north-aligned grid, so
    a :class:`~sarcli.io.georef.GeometryWarning` says so and None is returned (the grid is then
    derived from the sampling, east/north aligned and centred on the IARP).
    """
    g = xml.find("{*}SceneCoordinates/{*}ImageGrid")
    if g is None:
        return None
    planar = xml.find("{*}SceneCoordinates/{*}ReferenceSurface/{*}Planar")
    if planar is not None:
        uiax = np.array([float(planar.findtext(f"{{*}}uIAX/{{*}}{c}")) for c in "XYZ"])
        uiay = np.array([float(planar.findtext(f"{{*}}uIAY/{{*}}{c}")) for c in "XYZ"])
        basis = enu_basis(ref)
        ang = max(float(np.arccos(np.clip(uiax @ basis[0] / np.linalg.norm(uiax), -1, 1))),
                  float(np.arccos(np.clip(uiay @ basis[1] / np.linalg.norm(uiay), -1, 1))))
    else:
        ang = np.inf
    if not ang <= AXES_TOLERANCE_RAD:
        what = ("its image area is not planar" if planar is None else
                f"its image-area axes (uIAX, uIAY) are {np.degrees(ang):.4g} deg from East/North")
        warnings.warn(f"CPHD ImageGrid not used: {what}; sarcli images on an east/north-aligned grid "
                      "at the IARP, derived from the sampling (give --extent/--pixel-size to change it)",
                      GeometryWarning, stacklevel=4)
        return None
    dx = float(g.findtext("{*}IAXExtent/{*}LineSpacing"))
    dy = float(g.findtext("{*}IAYExtent/{*}SampleSpacing"))
    nx = int(g.findtext("{*}IAXExtent/{*}NumLines"))
    ny = int(g.findtext("{*}IAYExtent/{*}NumSamples"))
    line0 = float(g.findtext("{*}IARPLocation/{*}Line")) - int(g.findtext("{*}IAXExtent/{*}FirstLine"))
    samp0 = float(g.findtext("{*}IARPLocation/{*}Sample")) - int(g.findtext("{*}IAYExtent/{*}FirstSample"))
    return Grid(nx, ny, dx, dy, (nx // 2 - line0) * dx, (ny // 2 - samp0) * dy)
