"""controller.model.jit: compiled kernels, their cache keyed by every kernel source."""

from __future__ import annotations

from pathlib import Path

import pytest

from controller.model import jit


def test_the_digest_follows_every_kernel_source_and_nothing_else(tmp_path: Path) -> None:
    """A change in any file of the kernel packages that mentions jit changes the digest (a
    kernel that another one inlines included); other files do not."""
    for package in jit.KERNEL_PACKAGES:
        (tmp_path / package).mkdir(parents=True)
    chain = tmp_path / "controller/model/chain.py"
    chain.write_text("@jit\ndef forward(q):\n    return q\n")
    notes = tmp_path / "controller/model/notes.py"
    notes.write_text("X = 1\n")
    (tmp_path / "controller/gateway").mkdir()
    elsewhere = tmp_path / "controller/gateway/api.py"
    elsewhere.write_text("from controller.model.jit import jit\n")
    before = jit.kernel_sources_digest(tmp_path)
    notes.write_text("X = 2\n")
    elsewhere.write_text("from controller.model.jit import jit  # changed\n")
    assert jit.kernel_sources_digest(tmp_path) == before
    chain.write_text("@jit\ndef forward(q):\n    return -q\n")
    assert jit.kernel_sources_digest(tmp_path) != before


def test_a_kernels_cache_is_keyed_by_the_kernel_sources() -> None:
    """numba loads a kernel's cache only while the stamp it was saved with matches: ours
    carries the digest of every kernel source besides the kernel's own file (numba alone
    would keep the collision kernel's cache after a change in the joint chain it inlines)."""
    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    from controller.model import collision_kernel

    locator = collision_kernel.update._cache._impl.locator
    assert type(locator).__module__ == jit.__name__
    own, sources = locator.get_source_stamp()
    assert sources == jit.KERNEL_SOURCES == jit.kernel_sources_digest()
    assert own  # numba's own stamp of the kernel's file, kept


def test_a_compile_while_watched_is_reported_with_its_kernel_and_time() -> None:
    """watch_compiles names each kernel compiled (or loaded from the cache) for new argument
    types while it watches, once per compilation, with its time; nothing once stopped."""
    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    import numba
    import numpy as np

    def doubled(x):  # type: ignore[no-untyped-def]
        return 2.0 * x

    kernel = numba.njit(doubled)  # (no disk cache: a test's kernel)
    seen: list[tuple[str, float, str]] = []
    stop = jit.watch_compiles(lambda *report: seen.append(report))
    try:
        assert kernel(1.5) == 3.0
        assert kernel(2.5) == 5.0  # the same types: nothing new
    finally:
        stop()
    assert len(seen) == 1
    name, seconds, thread = seen[0]
    assert name == f"{__name__}.doubled" and seconds > 0.0 and thread == "MainThread"
    kernel(np.arange(3.0))  # new types, no longer watched
    assert len(seen) == 1


def test_compiled_meanwhile_lists_the_kernels_compiled_in_its_block() -> None:
    if not jit.available():
        pytest.skip("compiled kernels are off (no numba, or IMOTION_JIT=0)")
    import numba

    def halved(x):  # type: ignore[no-untyped-def]
        return 0.5 * x

    kernel = numba.njit(halved)  # (no disk cache: a test's kernel)
    with jit.compiled_meanwhile() as compiled:
        kernel(1.0)
        kernel(3.0)
    kernel(1)  # new types after the block: not listed
    assert compiled == [f"{__name__}.halved"]
