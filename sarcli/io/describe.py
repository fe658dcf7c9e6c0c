"""What ``sar info`` prints: a summary of any file sarcli reads, as plain JSON types.

Public API
----------
describe(path) -> dict
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["describe"]

_KINDS = {
    "config": "acquisition (YAML)", "phase-history": "phase history (sarcli HDF5)",
    "gotcha": "phase history (AFRL GOTCHA .mat)", "cphd": "phase history (CPHD)",
    "image": "image (sarcli HDF5)", "sicd": "image (SICD)", "geotiff": "image (GeoTIFF)",
    "kgrid": "k-grid (sarcli HDF5, PFA's Cartesian samples)",
}


def _image_summary(img) -> dict:
    grid = img.grid
    mag = np.abs(np.asarray(img.image))
    return {"method": img.method, "shape": list(img.image.shape), "dtype": str(np.asarray(img.image).dtype),
            "pixel_m": [grid.dx, grid.dy], "x_m": [float(img.x_m[0]), float(img.x_m[-1])],
            "y_m": [float(img.y_m[0]), float(img.y_m[-1])], "peak_magnitude": float(mag.max()) if mag.size else 0.0,
            "runtime_s": float(img.runtime_s) if np.isfinite(img.runtime_s) else "unknown",
            "parameters": img.parameters}


def describe(path) -> dict:
    """Summary of any file :func:`sarcli.io.open_input` reads.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict
        ``file``, ``format`` (the :data:`sarcli.io.FORMATS` key), ``kind`` (in words) and what
        matters for that kind: for an acquisition or a phase history the sampling (band, aperture,
        resolutions, alias-free radii, the default grid); for an image its grid, peak and the
        settings that made it; for a k-grid its size, spacing and centre.
    """
    from . import open_input

    from . import detect_format

    # a CPHD file's samples stay on disk (a summary of a large collection reads none of them);
    # a sarcli phase history is read whole, so that NaN/Inf in it is reported
    fmt, obj = open_input(path, lazy=detect_format(path) == "cphd")
    out = {"file": str(Path(path)), "format": fmt, "kind": _KINDS[fmt]}
    if fmt == "config":
        out.update(obj.summary())
        if obj.scene:
            out["scene"] = sorted(obj.scene)
    elif fmt in ("phase-history", "gotcha", "cphd"):
        out.update(obj.acquisition.summary())
        out["dtype"] = str(obj.data.dtype)
        if "sarcli_version" in obj.attrs:
            out["sarcli_version"] = obj.attrs["sarcli_version"]
        if obj.truth is not None:
            out["truth_points"] = int(len(obj.truth.point_amplitude))
        if fmt == "cphd":
            from .cphd import cphd_channels

            out["cphd_channels"] = [f"{c['identifier']} ({c['vectors']} x {c['samples']}, {c['polarization']})"
                                    for c in cphd_channels(path)]
            out.update({k: obj.attrs[k] for k in ("cphd_channel", "cphd_domain", "cphd_sgn_declared",
                                                   "cphd_sgn_used")})
            out["notes"] = list(obj.attrs.get("cphd_notes", []))
    elif fmt == "kgrid":
        out.update({"shape": list(obj.shape), "k0_rad_per_m": [obj.kx0, obj.ky0], "dk_rad_per_m": [obj.dkx, obj.dky],
                    "support_centre_rad_per_m": list(obj.kc), "parameters": obj.parameters})
    else:
        out.update(_image_summary(obj))
        lat, lon = obj.attrs.get("scene_center_lat_deg"), obj.attrs.get("scene_center_lon_deg")
        if lat is not None and lon is not None:
            out["scene_center_lat_lon_deg"] = [float(lat), float(lon)]
    return out
