"""Shared fixtures."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.support import ROBOT_IDS


def pytest_configure(config: pytest.Config) -> None:
    """numba's kernels compiled beside the collection (tests/jit_support.py)."""
    from tests import jit_support

    config.stash[_JIT_WORKERS] = jit_support.start()


def pytest_unconfigure(config: pytest.Config) -> None:
    """Workers a session did not wait for (``--collect-only``, an early end) are stopped."""
    for worker in config.stash.get(_JIT_WORKERS, []):
        if worker.returncode is None:  # not waited for
            worker.kill()
            worker.communicate()


_JIT_WORKERS = pytest.StashKey[list[Any]]()


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels(pytestconfig: pytest.Config) -> None:
    """numba's kernels in its on-disk cache before the first test (tests/jit_support.py):
    then neither this process nor a daemon a test starts compiles them while a test waits
    (on a fresh clone ~60 s of CPU, and twice where two processes started at once)."""
    from tests import jit_support

    jit_support.wait(pytestconfig.stash[_JIT_WORKERS])


@pytest.fixture(params=ROBOT_IDS)
def robot_id(request: pytest.FixtureRequest) -> str:
    return str(request.param)


#: The CORBA interface modules' daemon while they run (see :func:`corba_daemon`).
_CORBA: list[Any] = []


@pytest.fixture(scope="module")
def corba_daemon(request: pytest.FixtureRequest) -> Iterator[Any]:
    """One imotiond (SmartPal V, sim, CORBA on, IOR files) for the CORBA interface test
    modules, which run one after the other (:func:`pytest_collection_modifyitems`): each
    begins with ``back_to_start()`` and puts back the settings it changes. It is stopped
    after the last module that uses it (a daemon left running for the rest of the session
    would load the 2 cores all along), and replaced if a module left it dead. Was one per
    module: 12-19 s to start each."""
    pytest.importorskip("omniORB")
    from tests.corba_support import CorbaDaemon

    if _CORBA and _CORBA[0].proc.poll() is not None:
        _CORBA.pop().close()
    if not _CORBA:
        _CORBA.append(CorbaDaemon())
        request.config.add_cleanup(_stop_corba)  # a session ended early (-x, ^C) too
    try:
        yield _CORBA[0]
    finally:
        if not _used_later(request, "corba_daemon"):
            _stop_corba()


def _stop_corba() -> None:
    if _CORBA:
        _CORBA.pop().close()


def _used_later(request: pytest.FixtureRequest, fixture: str) -> bool:
    """Whether a test collected after ``request``'s module uses ``fixture``."""
    items = request.session.items
    module = request.node
    mine = [k for k, item in enumerate(items) if item.getparent(pytest.Module) is module]
    later = items[mine[-1] + 1 :] if mine else []
    return any(fixture in getattr(item, "fixturenames", ()) for item in later)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The tests using the shared CORBA daemon run together, where the first of them was (the
    daemon is not left running beside other modules)."""
    shared = [item for item in items if "corba_daemon" in getattr(item, "fixturenames", ())]
    if not shared:
        return
    first = items.index(shared[0])
    ids = {id(item) for item in shared}
    rest = [item for item in items if id(item) not in ids]
    items[:] = rest[:first] + shared + rest[first:]


@pytest.fixture(params=["compiled", "python"])
def jit_backend(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run a test with the compiled kernels (controller.model.jit) and again without them
    (``IMOTION_JIT=0``: coal, NumPy and Pinocchio alone, the fallback where numba is
    missing)."""
    if request.param == "python":
        monkeypatch.setenv("IMOTION_JIT", "0")
    else:
        monkeypatch.delenv("IMOTION_JIT", raising=False)
    return str(request.param)
