"""Keep one object bound in a CORBA naming service, across naming-service restarts.

``start`` creates the missing contexts and rebinds the name (replacing a binding left by
an earlier gateway); a thread checks every ``interval_s`` that the name still resolves to
our object and binds it again when it is missing (omniNames restarted without its data,
someone unbound it) or names a dead object. A name another *live* object took is left to
it (two daemons must not fight over one name): logged once. ``close`` stops the thread and
unbinds the name if it is still ours.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Sequence
from typing import Any

import CosNaming
import omniORB
from omniORB import CORBA

_log = logging.getLogger("imotiond.rtc")


def name_text(path: Sequence[tuple[str, str]]) -> str:
    """``a.host_cxt/b.rtc`` for ``[("a", "host_cxt"), ("b", "rtc")]``."""
    return "/".join(f"{i}.{k}" if k else i for i, k in path)


class NameBinding:
    def __init__(
        self, root: Any, path: Sequence[tuple[str, str]], obj: Any, interval_s: float
    ) -> None:
        self._root = root
        self._path = [CosNaming.NameComponent(i, k) for i, k in path]
        self._obj = obj
        self._interval = interval_s
        self.text = name_text(path)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._failing = False  # logged once per outage
        self._taken = False  # the name is another live object's (logged once)
        self.binds = 0  # how often the name was (re)bound (tests, logs)

    def start(self) -> None:
        """Bind now (a failure is logged and retried by the watcher) and start watching."""
        self.check(force=True)
        self._thread = threading.Thread(target=self._watch, name="rtc-naming", daemon=True)
        self._thread.start()

    def close(self, unbind: bool = True) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        if unbind:
            try:
                if self._lookup() == "ours":
                    self._root.unbind(self._path)
                    _log.info("naming: unbound %s", self.text)
            except CORBA.Exception as exc:
                _log.info("naming: could not unbind %s: %s", self.text, exc)

    def _watch(self) -> None:
        while not self._stop.wait(self._interval):
            try:
                self.check()
            except Exception:  # never let the watcher die silently: log, retry next time
                _log.exception("naming: checking %s failed", self.text)

    def check(self, force: bool = False) -> bool:
        """Bind the name when it is missing or names a dead object (``force``: whatever it
        names: at start, a binding left by an earlier gateway is replaced); True when bound."""
        try:
            found = self._lookup()
            if found == "ours" or (found == "other" and not force):
                if found == "other" and not self._taken:
                    _log.warning(
                        "naming: %s names another live object now: not taking it back",
                        self.text,
                    )
                self._taken = found == "other"
                return False
            self._bind()
        except CORBA.Exception as exc:  # system exceptions and CosNaming's user exceptions
            if not self._failing:
                _log.warning("naming: cannot bind %s (will retry): %s", self.text, exc)
            self._failing = True
            return False
        if self._failing:
            _log.info("naming: naming service back: %s bound again", self.text)
        self._failing = False
        self._taken = False
        self.binds += 1
        _log.info("naming: bound %s", self.text)
        return True

    def _lookup(self) -> str:
        """``ours``, ``missing``, ``dead`` (names an object that is gone) or ``other``."""
        try:
            found = self._root.resolve(self._path)
        except CosNaming.NamingContext.NotFound:
            return "missing"
        if CORBA.is_nil(found):
            return "dead"
        if found._is_equivalent(self._obj):
            return "ours"
        try:
            omniORB.setClientCallTimeout(found, 2000)
            return "dead" if found._non_existent() else "other"
        except CORBA.Exception:
            return "dead"

    def _bind(self) -> None:
        for i in range(1, len(self._path)):
            try:
                self._root.bind_new_context(self._path[:i])
            except CosNaming.NamingContext.AlreadyBound:
                pass  # the host context exists (other components live there too)
        self._root.rebind(self._path, self._obj)
