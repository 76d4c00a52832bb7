"""Keeps every servant bound in the naming service: at start, and again after the naming
service restarted (it forgets its bindings) or someone unbound a name. A thread re-checks
every ``interval`` seconds; each check is one ``resolve`` per name (and a ``rebind`` only for
a name that is missing or points elsewhere)."""

from __future__ import annotations

import logging
import threading
from typing import Any

import CosNaming
import omniORB
from omniORB import CORBA

_log = logging.getLogger("imotiond.corba")

#: Longest wait for one naming-service call [ms].
CALL_TIMEOUT_MS = 2000


class NamingBinder:
    def __init__(self, orb: Any, uri: str, names: dict[str, tuple[str, Any]], interval: float):
        """``names``: by key, (CosNaming string name, object reference)."""
        self.orb = orb
        self.uri = uri
        self.names = names
        self.interval = interval
        self.bound: dict[str, bool] = {key: False for key in names}
        self.checks = 0  #: completed checks (tests wait on this)
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="corba-naming", daemon=True)
        self._reported_down = False

    def start(self) -> None:
        self.check()
        self._thread.start()

    def _run(self) -> None:
        while not self._done.wait(self.interval):
            self.check()

    def _context(self) -> Any:
        obj = self.orb.string_to_object(self.uri)
        omniORB.setClientCallTimeout(obj, CALL_TIMEOUT_MS)
        ctx = obj._narrow(CosNaming.NamingContextExt)
        if ctx is None:
            raise RuntimeError(f"{self.uri} is not a naming context")
        return ctx

    def check(self) -> None:
        """Bind what is missing; never raises (a naming service that is down is logged
        once, and its return too)."""
        try:
            root = self._context()
            for key, (name, ref) in self.names.items():
                self._ensure(root, key, name, ref)
            if self._reported_down:
                _log.info("naming service %s is back: names bound again", self.uri)
            self._reported_down = False
        except (CORBA.Exception, RuntimeError) as exc:
            if not self._reported_down:
                _log.warning(
                    "naming service %s not reachable (%s): will retry every %g s",
                    self.uri,
                    type(exc).__name__,
                    self.interval,
                )
            self._reported_down = True
            self.bound = {key: False for key in self.names}
        self.checks += 1

    def _ensure(self, root: Any, key: str, name: str, ref: Any) -> None:
        path = root.to_name(name)
        try:
            if root.resolve(path)._is_equivalent(ref):
                self.bound[key] = True
                return
        except CosNaming.NamingContext.NotFound:
            pass
        ctx = root
        for i in range(len(path) - 1):  # the contexts on the way
            try:
                ctx = ctx.bind_new_context([path[i]])
            except CosNaming.NamingContext.AlreadyBound:
                ctx = ctx.resolve([path[i]])._narrow(CosNaming.NamingContext)
        ctx.rebind([path[-1]], ref)
        _log.info("bound %s in %s", name, self.uri)
        self.bound[key] = True

    def close(self, unbind: bool = True) -> None:
        """Stop the thread and unbind our names (best effort: only names still ours)."""
        self._done.set()
        if self._thread.is_alive():
            self._thread.join(timeout=CALL_TIMEOUT_MS / 1000.0 * 2)
        if not unbind:
            return
        try:
            root = self._context()
            for name, ref in self.names.values():
                path = root.to_name(name)
                try:
                    if root.resolve(path)._is_equivalent(ref):
                        root.unbind(path)
                except CosNaming.NamingContext.NotFound:
                    pass
        except (CORBA.Exception, RuntimeError):
            pass
