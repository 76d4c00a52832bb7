"""PDO layouts of an emulated drive, compiled from its object dictionary (CiA 301 §7.5).

The master maps PDOs over SDO (communication parameter 0x1400/0x1800 + n, mapping parameter
0x1600/0x1A00 + n). :func:`read_layout` turns the values the drive holds into a
:class:`PdoLayout`: COB-ID, validity, transmission type and one :class:`struct.Struct` for
the mapped objects, so the per-SYNC work is one ``pack``/``unpack`` per PDO.
:func:`check_mapping_entry` and :func:`check_mapping_count` are the SDO-side checks (abort
codes 0x06040041 "cannot be mapped", 0x06040042 "PDO length exceeded").
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from canopen import LocalNode, objectdictionary
from canopen.objectdictionary import datatypes
from canopen.sdo import SdoAbortedError

#: COB-ID bit 31: the PDO does not exist / is not valid.
PDO_NOT_VALID = 0x8000_0000
ABORT_NOT_MAPPABLE = 0x0604_0041
ABORT_PDO_TOO_LONG = 0x0604_0042

_FORMATS = {
    (datatypes.BOOLEAN, 8): "B",
    (datatypes.UNSIGNED8, 8): "B",
    (datatypes.INTEGER8, 8): "b",
    (datatypes.UNSIGNED16, 16): "H",
    (datatypes.INTEGER16, 16): "h",
    (datatypes.UNSIGNED32, 32): "I",
    (datatypes.INTEGER32, 32): "i",
    (datatypes.UNSIGNED64, 64): "Q",
    (datatypes.INTEGER64, 64): "q",
}


@dataclass(frozen=True)
class PdoLayout:
    """One PDO as configured: where it goes and what it carries."""

    #: 11-bit CAN identifier.
    cob_id: int
    #: COB-ID bit 31 clear and at least one object mapped.
    enabled: bool
    #: 0 acyclic synchronous, 1..240 every n-th SYNC, 254/255 event driven.
    trans_type: int
    #: Mapped objects as (index, subindex), in frame order.
    entries: tuple[tuple[int, int], ...]
    #: Little-endian packer of the mapped objects.
    packer: struct.Struct


def _raw(node: LocalNode, index: int, subindex: int) -> int:
    var = _variable(node, index, subindex)
    return int(var.decode_raw(node.get_data(index, subindex)))


def _variable(node: LocalNode, index: int, subindex: int) -> objectdictionary.ODVariable:
    obj = node.object_dictionary[index]
    if isinstance(obj, objectdictionary.ODVariable):
        return obj
    return obj[subindex]


def entry_format(node: LocalNode, value: int) -> tuple[int, int, str]:
    """``(index, subindex, struct code)`` of a mapping entry; SdoAbortedError if unmappable."""
    index, subindex, bits = value >> 16, (value >> 8) & 0xFF, value & 0xFF
    try:
        var = _variable(node, index, subindex)
    except KeyError:
        raise SdoAbortedError(ABORT_NOT_MAPPABLE) from None
    code = _FORMATS.get((var.data_type or 0, bits))
    if code is None or not var.pdo_mappable:
        raise SdoAbortedError(ABORT_NOT_MAPPABLE)
    return index, subindex, code


def check_mapping_entry(node: LocalNode, value: int) -> None:
    """Reject (SDO abort) a mapping entry naming an object that cannot be mapped."""
    if value != 0:
        entry_format(node, value)


def check_mapping_count(node: LocalNode, map_index: int, count: int) -> None:
    """Reject (SDO abort) a number of mapped objects whose total exceeds 64 bits."""
    if count > 8:
        raise SdoAbortedError(ABORT_PDO_TOO_LONG)
    bits = 0
    for sub in range(1, count + 1):
        value = _raw(node, map_index, sub)
        entry_format(node, value)
        bits += value & 0xFF
    if bits > 64:
        raise SdoAbortedError(ABORT_PDO_TOO_LONG)


def read_layout(node: LocalNode, comm_index: int, map_index: int) -> PdoLayout:
    """The PDO configured at ``comm_index``/``map_index`` of ``node`` (values as stored)."""
    cob = _raw(node, comm_index, 1)
    trans_type = _raw(node, comm_index, 2)
    count = _raw(node, map_index, 0)
    entries = []
    codes = []
    for sub in range(1, count + 1):
        index, subindex, code = entry_format(node, _raw(node, map_index, sub))
        entries.append((index, subindex))
        codes.append(code)
    return PdoLayout(
        cob_id=cob & 0x7FF,
        enabled=not cob & PDO_NOT_VALID and bool(entries),
        trans_type=trans_type,
        entries=tuple(entries),
        packer=struct.Struct("<" + "".join(codes)),
    )
