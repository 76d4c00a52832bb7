"""numba, where the hot path needs compiled code: availability and the one way to compile.

Kernels (:mod:`controller.model.collision_kernel`, :mod:`controller.model.elbow`,
:mod:`controller.qp.constraints.damper_kernel`) are plain Python functions on NumPy arrays
and floats, compiled with :func:`jit` when numba imports. Where it does not, or with
``IMOTION_JIT=0`` in the environment, :func:`available` is False and their callers use their
NumPy/Pinocchio code instead (the same results, slower; tests run both). Compiled code is
cached on disk (beside the sources, or in ``NUMBA_CACHE_DIR``); callers compile or load it
when they are built, never in a control cycle.

numba keeps a kernel's cache while the kernel's own source file is unchanged, and compiles
the kernels it calls from other modules into it: a change in those (a joint chain kernel
that the collision and elbow kernels inline) would not be seen, and the stale code would
run. So a kernel's cache here is also keyed by :data:`KERNEL_SOURCES`, a digest of every
source file of the kernel packages that mentions ``jit``: any change in one of them
compiles every kernel again at the next start (about 40 s of CPU).
"""

from __future__ import annotations

import hashlib
import os
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar, cast

try:  # pragma: no cover - exercised by the import itself
    import numba
    from numba.core import caching
except ImportError:  # pragma: no cover - the fallback is tested with IMOTION_JIT=0
    numba = None  # type: ignore[assignment]

F = TypeVar("F", bound=Callable[..., Any])

#: Where the kernels live (every file under them that mentions ``jit`` is in the digest).
_ROOT = Path(__file__).resolve().parents[2]
KERNEL_PACKAGES = ("controller/model", "controller/qp", "controller/motion", "hal")


def kernel_sources_digest(root: Path = _ROOT) -> bytes:
    """SHA-256 over the path and contents of every ``.py`` file under
    :data:`KERNEL_PACKAGES` whose text mentions ``jit`` (~5 ms)."""
    digest = hashlib.sha256()
    for package in KERNEL_PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            text = path.read_bytes()
            if b"jit" in text:
                digest.update(path.relative_to(root).as_posix().encode())
                digest.update(text)
    return digest.digest()


#: :func:`kernel_sources_digest` of the sources this process runs (read only where numba
#: is: nothing is cached without it).
KERNEL_SOURCES = kernel_sources_digest() if numba is not None else b""


def _stamp_with_kernel_sources(locator: Any, stamp: Any) -> Any:
    """A cache entry's source stamp, with :data:`KERNEL_SOURCES` for files of ours."""
    if Path(locator._py_file).resolve().is_relative_to(_ROOT):
        return (stamp, KERNEL_SOURCES)
    return stamp


if numba is not None:

    class UserProvidedLocator(caching.UserProvidedCacheLocator):
        """numba's ``NUMBA_CACHE_DIR`` locator, the stamp keyed by the kernel sources."""

        def get_source_stamp(self) -> Any:
            return _stamp_with_kernel_sources(self, super().get_source_stamp())

    class InTreeLocator(caching.InTreeCacheLocator):
        """numba's ``__pycache__`` locator, the stamp keyed by the kernel sources."""

        def get_source_stamp(self) -> Any:
            return _stamp_with_kernel_sources(self, super().get_source_stamp())

    class UserWideLocator(caching.UserWideCacheLocator):
        """numba's per-user locator, the stamp keyed by the kernel sources."""

        def get_source_stamp(self) -> Any:
            return _stamp_with_kernel_sources(self, super().get_source_stamp())

    if not numba.config.CACHE_LOCATOR_CLASSES:  # type: ignore[attr-defined]  # (a user's stays)
        numba.config.CACHE_LOCATOR_CLASSES = ",".join(  # type: ignore[attr-defined]
            [f"{__name__}.{name}" for name in ("UserProvidedLocator", "InTreeLocator")]
            + [f"{__name__}.UserWideLocator", "IPythonCacheLocator", "ZipCacheLocator"]
        )


def available() -> bool:
    """Whether compiled kernels can be used (numba imports and ``IMOTION_JIT`` is not 0)."""
    return numba is not None and os.environ.get("IMOTION_JIT", "1") != "0"


def jit(function: F) -> F:
    """Compile with numba where it exists: cached on disk, no Python objects, GIL released,
    NumPy's error model (a division by zero gives inf/NaN instead of raising)."""
    if numba is None:  # pragma: no cover
        return function
    return cast(F, numba.njit(cache=True, nogil=True, error_model="numpy")(function))


#: The packages whose compiled kernels :func:`loaded_kernels` lists.
PROJECT_PACKAGES = ("controller", "hal")


def loaded_kernels() -> dict[str, Any]:
    """Every compiled kernel of this project in the modules imported so far, by qualified
    name (``module.function``): numba dispatchers defined at a module's top level. Their
    ``signatures`` grow by one each time a kernel compiles for new argument types, which
    must never happen in a control cycle (the tests compare them around cycles)."""
    if numba is None:  # pragma: no cover
        return {}
    dispatcher = numba.core.registry.CPUDispatcher
    found: dict[str, Any] = {}
    for name, module in list(sys.modules.items()):
        if module is None or name.split(".")[0] not in PROJECT_PACKAGES:
            continue
        for value in list(vars(module).values()):
            if isinstance(value, dispatcher) and value.py_func.__module__ == name:
                found[f"{name}.{value.py_func.__name__}"] = value
    return found


def _compiling_kernel() -> str:
    """The kernel whose compilation (or cache load) the calling thread is in: the
    ``module.function`` of the dispatcher in the nearest ``compile`` frame of the stack."""
    frame = sys._getframe(1)
    while frame is not None:
        owner = frame.f_locals.get("self") if frame.f_code.co_name == "compile" else None
        function = getattr(owner, "py_func", None)
        if function is not None:
            return f"{function.__module__}.{function.__name__}"
        frame = frame.f_back  # type: ignore[assignment]
    return "a numba function"


def watch_compiles(report: Callable[[str, float, str], None]) -> Callable[[], None]:
    """From now on, ``report(kernel, seconds, thread)`` after each compilation of a kernel
    for new argument types, or its load from numba's cache, in any thread of this process
    (numba's compiler lock, held throughout: the outermost one per thread). Returns the
    function that stops watching. The control loop watches while it runs: a kernel compiled
    in a cycle stalls it for up to seconds (the drives then lose the master's heartbeat), so
    every kernel is compiled or loaded before the loop starts, and one that is not says so."""
    if numba is None:  # pragma: no cover
        return lambda: None
    from numba.core import event

    class _Watch(event.Listener):
        def __init__(self) -> None:
            self.open: dict[int, tuple[int, float, str]] = {}  # thread: depth, start, kernel

        def on_start(self, ev: object) -> None:
            thread = threading.get_ident()
            depth, start, kernel = self.open.get(thread, (0, 0.0, ""))
            if depth == 0:
                start, kernel = time.perf_counter(), _compiling_kernel()
            self.open[thread] = (depth + 1, start, kernel)

        def on_end(self, ev: object) -> None:
            thread = threading.get_ident()
            depth, start, kernel = self.open.pop(thread, (1, time.perf_counter(), "?"))
            if depth > 1:
                self.open[thread] = (depth - 1, start, kernel)
                return
            report(kernel, time.perf_counter() - start, threading.current_thread().name)

    listener = _Watch()
    event.register("numba:compiler_lock", listener)
    return lambda: event.unregister("numba:compiler_lock", listener)


@contextmanager
def compiled_meanwhile() -> Iterator[list[str]]:
    """The kernels compiled (or loaded from numba's cache) for new argument types while the
    block runs, in order (:func:`watch_compiles` into a list: a benchmark's loop)."""
    compiled: list[str] = []
    stop = watch_compiles(lambda kernel, seconds, thread: compiled.append(kernel))
    try:
        yield compiled
    finally:
        stop()
