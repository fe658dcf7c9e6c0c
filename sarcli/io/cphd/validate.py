"""What makes a CPHD file unreadable, found before any sample is read: one line naming the file.

Checked: the file header and XML (sarkit), the channel asked for, the domain, compression, the
sizes the XML promises against the header's blocks and the file's length, the PVP layout against
``NumBytesPVP``, and NaN/Inf in the PVPs that image formation uses.
"""

from __future__ import annotations

import numpy as np

from ...errors import InputFileError

__all__ = ["open_header", "select_channel", "check_layout", "check_pvps", "channel_table"]

#: PVPs that image formation reads: NaN/Inf in any kept vector is refused.
_USED_PVPS = ("TxTime", "TxPos", "RcvTime", "RcvPos", "SRPPos", "SC0", "SCSS", "FX1", "FX2",
              "TOA1", "TOA2", "TDTropoSRP", "AmpSF")


def open_header(p):
    """The XML tree and header key/values of CPHD file ``p`` (InputFileError when unreadable)."""
    import lxml.etree
    import sarkit.cphd as skcphd

    with open(p, "rb") as f:
        if f.read(5) != b"CPHD/":
            raise InputFileError(p, "not a CPHD file (it does not start with 'CPHD/')")
        f.seek(0)
        try:
            _, kvp = skcphd.read_file_header(f)
            f.seek(0)
            with skcphd.Reader(f) as r:
                xml = r.metadata.xmltree
        except (ValueError, KeyError, OSError, lxml.etree.LxmlError) as exc:
            raise InputFileError(p, "truncated or corrupt CPHD file: its header or XML block cannot be "
                                    f"read ({type(exc).__name__}: {str(exc)[:80]})") from None
    return xml, kvp


def channel_table(xml) -> list[dict]:
    """Every channel of the file: identifier, vectors, samples, polarisation (``sar info``)."""
    out = []
    for node in xml.findall("{*}Data/{*}Channel"):
        ident = node.findtext("{*}Identifier")
        par = xml.find(f"{{*}}Channel/{{*}}Parameters[{{*}}Identifier='{ident}']")
        pol = "" if par is None else ((par.findtext("{*}Polarization/{*}TxPol") or "")
                                      + (par.findtext("{*}Polarization/{*}RcvPol") or ""))
        out.append({"identifier": ident, "vectors": int(node.findtext("{*}NumVectors")),
                    "samples": int(node.findtext("{*}NumSamples")),
                    "polarization": pol if len(pol) == 2 and set(pol) <= set("HV") else "unspecified"})
    return out


def select_channel(p, xml, channel) -> tuple[str, list[str]]:
    """The identifier of the channel asked for, and the note saying which one when not asked.

    ``channel`` is an identifier, or else a 0-based index (an identifier wins: ``'1'`` is the
    channel named 1); None is the first channel.
    """
    ids = [c["identifier"] for c in channel_table(xml)]
    if not ids:
        raise InputFileError(p, "CPHD file without channels (Data/Channel)")
    listed = ", ".join(repr(i) for i in ids)
    if channel is None:
        note = ([f"CPHD file with {len(ids)} channels ({listed}): reading the first, '{ids[0]}' "
                 "(--channel NAME|INDEX for another)"] if len(ids) > 1 else [])
        return ids[0], note
    text = str(channel).strip()
    if text in ids:
        return text, []
    if text.lstrip("-").isdigit() and 0 <= int(text) < len(ids):
        return ids[int(text)], []
    raise InputFileError(p, f"no CPHD channel {text!r}: the file has {listed} (give a name or an index "
                            f"0-{len(ids) - 1})")


def check_layout(p, xml, kvp, ch: str) -> None:
    """Domain, compression and sizes of channel ``ch`` against the header and the file."""
    import sarkit.cphd as skcphd

    domain = xml.findtext("{*}Global/{*}DomainType")
    if domain not in ("FX", "TOA"):
        raise InputFileError(p, f"CPHD DomainType {domain!r} is not FX or TOA")
    node = xml.find(f"{{*}}Data/{{*}}Channel[{{*}}Identifier='{ch}']")
    if node.findtext("{*}CompressedSignalSize") is not None:
        codec = xml.findtext("{*}Data/{*}SignalCompressionID")
        raise InputFileError(p, f"compressed CPHD signal array (channel '{ch}', SignalCompressionID {codec!r}): "
                                "sarkit reads compressed arrays only as raw bytes and sarcli has no decoder "
                                f"for {codec!r}; decompress it first")
    nv, ns = int(node.findtext("{*}NumVectors")), int(node.findtext("{*}NumSamples"))
    nbytes = int(xml.findtext("{*}Data/{*}NumBytesPVP"))
    fmt = xml.findtext("{*}Data/{*}SignalArrayFormat")
    item = skcphd.binary_format_string_to_dtype(fmt).itemsize
    pvp_have = int(kvp["PVP_BLOCK_SIZE"]) - int(node.findtext("{*}PVPArrayByteOffset"))
    if pvp_have < nv * nbytes:
        raise InputFileError(p, f"CPHD PVP and signal sizes disagree: channel '{ch}' has {nv} signal vectors "
                                f"(NumVectors) but its PVP array holds {max(pvp_have, 0) // nbytes} "
                                f"({max(pvp_have, 0)} bytes of {nbytes} per vector)")
    sig_have = int(kvp["SIGNAL_BLOCK_SIZE"]) - int(node.findtext("{*}SignalArrayByteOffset"))
    if sig_have < nv * ns * item:
        raise InputFileError(p, f"CPHD PVP and signal sizes disagree: channel '{ch}' has {nv} PVP vectors of "
                                f"{ns} {fmt} samples ({nv * ns * item} bytes) but its signal array holds "
                                f"{max(sig_have, 0)} bytes")
    for field in xml.find("{*}PVP"):
        if field.find("{*}Offset") is None:
            continue
        end = 8 * (int(field.findtext("{*}Offset")) + int(field.findtext("{*}Size")))
        if end > nbytes:
            name = field.findtext("{*}Name") or field.tag.rsplit("}", 1)[-1]
            raise InputFileError(p, f"CPHD PVP {name} ends at byte {end} of a {nbytes}-byte vector (NumBytesPVP)")
    size = p.stat().st_size
    need = int(kvp["SIGNAL_BLOCK_BYTE_OFFSET"]) + int(kvp["SIGNAL_BLOCK_SIZE"])
    if size < need:
        raise InputFileError(p, f"truncated CPHD file: {size} bytes, the header promises {need}")


def check_pvps(p, pvp, ch: str, kept) -> None:
    """NaN/Inf in a PVP that image formation uses, in a vector it keeps: one line naming them."""
    rows = pvp if kept is None else pvp[kept]
    for name in _USED_PVPS:
        if name not in pvp.dtype.names:
            continue
        vals = np.asarray(rows[name], np.float64).reshape(len(rows), -1)
        bad = np.flatnonzero(~np.all(np.isfinite(vals), axis=1))
        if bad.size:
            vec = bad if kept is None else np.asarray(kept)[bad]
            shown = ", ".join(str(int(v)) for v in vec[:5]) + (", ..." if vec.size > 5 else "")
            raise InputFileError(p, f"CPHD PVP {name} is NaN/Inf in {bad.size} of {len(rows)} vectors of channel "
                                    f"'{ch}' (vector {shown})")
