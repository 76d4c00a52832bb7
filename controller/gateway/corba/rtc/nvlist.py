"""SDO name-value lists (``SDOPackage::NVList``): OpenRTM stores strings in them as anys."""

from __future__ import annotations

from typing import Any

from omniORB import any as corba_any
from rtctree.rtc import SDOPackage


def nv(name: str, value: str) -> Any:
    """One ``NameValue`` holding a string (as OpenRTM writes IORs and properties)."""
    return SDOPackage.NameValue(name, corba_any.to_any(value))


def nvlist(values: dict[str, str]) -> list[Any]:
    return [nv(name, value) for name, value in values.items()]


def nv_text(item: Any) -> str | None:
    """The string in a ``NameValue``; None when it holds something else."""
    try:
        value = corba_any.from_any(item.value, keep_structs=True)
    except Exception:  # an any we cannot decode: not one of ours
        return None
    return value if isinstance(value, str) else None


def nv_find(items: list[Any], name: str) -> str | None:
    """The string value named ``name`` (the first one), or None."""
    for item in items:
        if item.name == name:
            return nv_text(item)
    return None
