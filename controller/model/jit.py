"""numba, where the hot path needs compiled code: availability and the one way to compile.

Kernels (:mod:`controller.model.collision_kernel`, :mod:`controller.model.elbow`,
:mod:`controller.qp.constraints.damper_kernel`) are plain Python functions on NumPy arrays
and floats, compiled with :func:`jit` when numba imports. Where it does not, or with
``IMOTION_JIT=0`` in the environment, :func:`available` is False and their callers use their
NumPy/Pinocchio code instead (the same results, slower; tests run both). Compiled code is
cached on disk (beside the sources, or in ``NUMBA_CACHE_DIR``); callers compile or load it
when they are built, never in a control cycle.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, TypeVar, cast

try:  # pragma: no cover - exercised by the import itself
    import numba
except ImportError:  # pragma: no cover - the fallback is tested with IMOTION_JIT=0
    numba = None  # type: ignore[assignment]

F = TypeVar("F", bound=Callable[..., Any])


def available() -> bool:
    """Whether compiled kernels can be used (numba imports and ``IMOTION_JIT`` is not 0)."""
    return numba is not None and os.environ.get("IMOTION_JIT", "1") != "0"


def jit(function: F) -> F:
    """Compile with numba where it exists: cached on disk, no Python objects, GIL released,
    NumPy's error model (a division by zero gives inf/NaN instead of raising)."""
    if numba is None:  # pragma: no cover
        return function
    return cast(F, numba.njit(cache=True, nogil=True, error_model="numpy")(function))
