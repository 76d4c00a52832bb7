"""Support for the RT component tests: omniNames on 127.0.0.1, a test IDL compiled at test
time, an OpenRTM-style consumer component, rtshell as subprocesses."""

from __future__ import annotations

import importlib
import os
import random
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jeteve_omniorb
from omniORB import CORBA
from rtctree.rtc import RTC, RTC__POA

from controller.gateway.corba.rtc.component import RtObject
from controller.gateway.corba.rtc.context import ExecutionContext
from controller.gateway.corba.rtc.nvlist import nv, nv_find
from controller.gateway.corba.rtc.sdo import Configuration

OMNINAMES = Path(jeteve_omniorb.__file__).parent / "bin" / "omniNames"
BIN = Path(sys.executable).parent
TEST_IDL = """
module RtcTest {
  struct RETURN_ID { long id; string comment; };
  interface Probe {
    RETURN_ID getState(out unsigned long state);
    RETURN_ID getVersion(out string version);
  };
};
"""
PROBE_TYPE = "RtcTest::Probe"


def wait_for(condition: Callable[[], Any], timeout: float = 60.0, what: str = "") -> Any:
    """Poll ``condition`` until truthy (its value) or fail after ``timeout`` [s]."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what or condition}")
        time.sleep(0.05)


# -- omniNames ---------------------------------------------------------------------------------


class NamingService:
    """omniNames on 127.0.0.1: a random high port, another one if that is taken (no
    bind-then-close race: omniNames itself binds, and says so when it cannot)."""

    def __init__(self, data_dir: Path, port: int | None = None):
        self.data_dir = data_dir
        self.proc: subprocess.Popen[str] | None = None
        self.port = port or 0
        self.start(port)

    def start(self, port: int | None = None, fresh: bool = True) -> None:
        """Start (again). ``fresh``: forget earlier bindings (a new data directory)."""
        rng = random.Random()
        for _ in range(20):
            candidate = port or rng.randrange(20000, 60000)
            data = self.data_dir / f"names-{candidate}-{time.monotonic_ns()}"
            data.mkdir(parents=True)
            cmd = [str(OMNINAMES), "-start", str(candidate), "-always", "-datadir", str(data)]
            cmd += ["-ORBendPoint", f"giop:tcp:127.0.0.1:{candidate}"]
            proc = subprocess.Popen(
                cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
            )
            assert proc.stdout is not None
            lines = []
            for line in proc.stdout:
                lines.append(line)
                if "Root context is" in line:
                    break
            else:
                proc.wait()
                text = "".join(lines)
                if "Failed to bind" in text or "Address in use" in text:
                    if port:  # a fixed port (restart): wait until the old socket is gone
                        time.sleep(0.1)
                    continue
                raise RuntimeError(f"omniNames failed: {text}")
            threading.Thread(target=self._drain, args=(proc,), daemon=True).start()
            self.proc = proc
            self.port = candidate
            return
        raise RuntimeError("omniNames: no free port after 20 tries")

    @staticmethod
    def _drain(proc: subprocess.Popen[str]) -> None:
        assert proc.stdout is not None
        for _ in proc.stdout:
            pass

    @property
    def address(self) -> str:
        return f"127.0.0.1:{self.port}"

    @property
    def corbaloc(self) -> str:
        return f"corbaloc::127.0.0.1:{self.port}/NameService"

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc = None

    def restart(self) -> None:
        """Stop and start on the same port with an empty data directory."""
        port = self.port
        self.stop()
        self.start(port)


def naming_root(orb: Any, naming: NamingService) -> Any:
    import CosNaming

    # Unchecked: no call now (the naming service may be restarting).
    return orb.string_to_object(naming.corbaloc)._unchecked_narrow(CosNaming.NamingContext)


def resolve(root: Any, text: str) -> Any:
    """The object bound as ``a.kind/b.kind`` (None when unbound or unreachable)."""
    import CosNaming

    path = [CosNaming.NameComponent(*part.rsplit(".", 1)) for part in text.split("/")]
    try:
        return root.resolve(path)
    except (CosNaming.NamingContext.NotFound, CORBA.COMM_FAILURE, CORBA.TRANSIENT):
        return None  # unbound, or the naming service is (re)starting


# -- ORB and the test IDL ------------------------------------------------------------------------


_ORB: tuple[Any, Any] | None = None


def orb_and_poa() -> tuple[Any, Any]:
    """This process's ORB (listening on 127.0.0.1 only) and its active root POA."""
    global _ORB
    if _ORB is None:
        orb = CORBA.ORB_init([sys.argv[0], "-ORBendPoint", "giop:tcp:127.0.0.1:"], CORBA.ORB_ID)
        poa = orb.resolve_initial_references("RootPOA")
        poa._get_the_POAManager().activate()
        _ORB = (orb, poa)
    return _ORB


def compile_test_idl(out_dir: Path) -> tuple[Any, Any]:
    """omniidl the test IDL into ``out_dir``; returns (RtcTest, RtcTest__POA)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    idl = out_dir / "rtc_test.idl"
    idl.write_text(TEST_IDL)
    subprocess.run(
        [str(BIN / "omniidl"), "-bpython", "-C", str(out_dir), str(idl)],
        check=True,
        capture_output=True,
    )
    if str(out_dir) not in sys.path:
        sys.path.insert(0, str(out_dir))
    return importlib.import_module("RtcTest"), importlib.import_module("RtcTest__POA")


def probe_servant(mod: Any, poa_mod: Any) -> Any:
    """A Probe answering getState (7, "probe ok") and getVersion ("probe 1.0")."""

    class Probe(poa_mod.Probe):  # type: ignore[misc, name-defined]
        calls = 0

        def getState(self) -> Any:
            Probe.calls += 1
            return mod.RETURN_ID(0, "probe ok"), 7

        def getVersion(self) -> Any:
            Probe.calls += 1
            return mod.RETURN_ID(0, ""), "probe 1.0"

    return Probe()


# -- a consumer component, as an OpenRTM application has -----------------------------------------


class ConsumerPort(RTC__POA.PortService):
    """A CorbaPort with one REQUIRED interface, following OpenRTM's consumer side: on
    notify_connect it forwards to the next port, then picks the provider's IOR from the
    returned connector properties (``port.<type>.<instance>``) and narrows it."""

    def __init__(self, orb: Any, owner: str, port: str, type_name: str, instance: str, cls: Any):
        self.orb, self.owner_name, self.port_name = orb, owner, port
        self.type_name, self.instance, self.cls = type_name, instance, cls
        self.ref: Any = None
        self.owner: Any = None
        self.connectors: list[Any] = []
        self.provider: Any = None  # the narrowed object once connected
        self.lock = threading.Lock()

    def attach(self, ref: Any, owner: Any) -> None:
        self.ref, self.owner = ref, owner

    def get_port_profile(self) -> Any:
        itf = RTC.PortInterfaceProfile(self.instance, self.type_name, RTC.REQUIRED)
        props = [nv("port.port_type", "CorbaPort")]
        with self.lock:
            conns = list(self.connectors)
        name = f"{self.owner_name}.{self.port_name}"
        return RTC.PortProfile(name, [itf], self.ref, conns, self.owner, props)

    def get_connector_profiles(self) -> list[Any]:
        with self.lock:
            return list(self.connectors)

    def get_connector_profile(self, cid: str) -> Any:
        with self.lock:
            for c in self.connectors:
                if c.connector_id == cid:
                    return c
        return RTC.ConnectorProfile("", "", [], [])

    def connect(self, profile: Any) -> Any:
        if not profile.connector_id:
            profile.connector_id = f"consumer-{time.monotonic_ns()}"
        return profile.ports[0].notify_connect(profile)

    def notify_connect(self, profile: Any) -> Any:
        index = next(i for i, p in enumerate(profile.ports) if p._is_equivalent(self.ref))
        ret = RTC.RTC_OK
        if index + 1 < len(profile.ports):
            ret, profile = profile.ports[index + 1].notify_connect(profile)
        ior = nv_find(profile.properties, f"port.{self.type_name}.{self.instance}")
        if ior is not None and ior.startswith("IOR:"):
            self.provider = self.orb.string_to_object(ior)._narrow(self.cls)
        with self.lock:
            self.connectors.append(profile)
        return ret, profile

    def disconnect(self, cid: str) -> Any:
        profile = self.get_connector_profile(cid)
        if not profile.ports:
            return RTC.BAD_PARAMETER
        return profile.ports[0].notify_disconnect(cid)

    def notify_disconnect(self, cid: str) -> Any:
        profile = self.get_connector_profile(cid)
        if not profile.ports:
            return RTC.BAD_PARAMETER
        index = next(i for i, p in enumerate(profile.ports) if p._is_equivalent(self.ref))
        ret = RTC.RTC_OK
        if index + 1 < len(profile.ports):
            ret = profile.ports[index + 1].notify_disconnect(cid)
        with self.lock:
            self.connectors = [c for c in self.connectors if c.connector_id != cid]
        self.provider = None
        return ret

    def disconnect_all(self) -> Any:
        for c in self.get_connector_profiles():
            self.disconnect(c.connector_id)
        return RTC.RTC_OK


@dataclass
class Consumer:
    """A consumer component registered as ``<host>.host_cxt/<name>.rtc``."""

    name: str
    port: ConsumerPort
    ref: Any
    oids: list[Any] = field(default_factory=list)


def consumer_component(
    orb: Any, poa: Any, name: str, port: str, type_name: str, instance: str, cls: Any
) -> Consumer:
    cport = ConsumerPort(orb, name, port, type_name, instance, cls)
    profile = {
        "instance_name": name,
        "type_name": "TestConsumer",
        "description": "test consumer",
        "version": "1.0",
        "vendor": "tests",
        "category": "test",
    }
    comp = RtObject(profile, profile, [cport], on_exit=lambda: None)  # type: ignore[list-item]
    ec = ExecutionContext(comp, 100.0)
    conf = Configuration({})
    oids = [poa.activate_object(s) for s in (comp, ec, conf, cport)]
    refs = [poa.id_to_reference(o) for o in oids]
    comp.attach(refs[0], ec, refs[1], refs[2])
    ec.attach(refs[1], refs[0])
    cport.attach(refs[3], refs[0])
    return Consumer(name, cport, refs[0], oids)


def bind_consumer(root: Any, host: str, consumer: Consumer) -> None:
    import CosNaming

    try:
        root.bind_new_context([CosNaming.NameComponent(host, "host_cxt")])
    except CosNaming.NamingContext.AlreadyBound:
        pass
    path = [
        CosNaming.NameComponent(host, "host_cxt"),
        CosNaming.NameComponent(consumer.name, "rtc"),
    ]
    root.rebind(path, consumer.ref)


# -- rtshell ---------------------------------------------------------------------------------------


def rtshell(naming: NamingService, *args: str, check: bool = True) -> str:
    """Run an rtshell tool against ``naming``; its stdout (stderr appended on failure)."""
    env = dict(os.environ)
    env["RTCTREE_NAMESERVERS"] = naming.address
    env["RTCTREE_ORB_ARGS"] = "-ORBendPoint;giop:tcp:127.0.0.1:"
    done = subprocess.run(
        [str(BIN / args[0]), *args[1:]], env=env, capture_output=True, text=True, timeout=120
    )
    if check and done.returncode != 0:
        raise AssertionError(f"{' '.join(args)} -> {done.returncode}\n{done.stdout}{done.stderr}")
    return done.stdout + ("" if done.returncode == 0 else done.stderr)
