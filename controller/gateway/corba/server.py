"""The CORBA side of the gateway: the ORB, the POA, every servant the robot has, their
registration (naming service, IOR files) and, optionally, omniNames itself.

One ORB per process (omniORB's ORB is a process-wide singleton): :func:`start_corba` refuses
a second server while one runs. omniORB serves requests on its own thread pool; nothing
here needs ``orb.run()``.

For the RT component (issue 11, part B): :class:`CorbaServer` exposes ``orb``, ``poa``,
and per servant key its object reference (``refs``) and IDL type name (``type_names``, e.g.
``JARA_ARM::ManipulatorCommonInterface_Middle``).
"""

from __future__ import annotations

import logging
import os
import shutil
import signal
import subprocess
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from omniORB import CORBA

from controller.contract.config import DaemonConfig
from controller.gateway.corba.dual import DualCommonServant, DualMiddleServant
from controller.gateway.corba.jara import JARA_LEFT, JARA_RIGHT, common_servant, middle_servant
from controller.gateway.corba.naming import NamingBinder
from controller.gateway.corba.spec_a import SpecAServant
from controller.gateway.services.registry import Services
from controller.vocabulary import RightLeft

_log = logging.getLogger("imotiond.corba")

#: omniNames of the jeteve-omniorb wheel (its console script does not pass SIGTERM on).
OMNINAMES_START_TIMEOUT = 10.0

_running: CorbaServer | None = None
_lock = threading.Lock()


@dataclass
class CorbaServer:
    orb: Any  #: CORBA.ORB
    poa: Any  #: the root POA (transient object references)
    servants: dict[str, Any]  #: by key of ``corba.names`` (spec_a, jara_arm_middle, ...)
    refs: dict[str, Any]  #: object references, same keys
    type_names: dict[str, str]  #: IDL scoped names, same keys
    naming: NamingBinder | None = None
    omninames: subprocess.Popen[bytes] | None = None
    ior_files: list[Path] = field(default_factory=list)

    def ior(self, key: str) -> str:
        return str(self.orb.object_to_string(self.refs[key]))

    def close(self) -> None:
        """Unbind the names, deactivate the servants, destroy the ORB, stop omniNames (an
        omniNames of our own goes first: nothing to unbind in a naming service that stops)."""
        global _running
        if self.omninames is not None:
            stop_omninames(self.omninames)
        if self.naming is not None:
            self.naming.close(unbind=self.omninames is None)
        for path in self.ior_files:
            path.unlink(missing_ok=True)
        for servant in self.servants.values():
            try:
                self.poa.deactivate_object(self.poa.servant_to_id(servant))
            except Exception:  # already gone (ORB shut down)
                pass
        try:
            self.orb.shutdown(True)
            self.orb.destroy()
        except Exception:
            _log.exception("CORBA ORB shutdown failed")
        with _lock:
            _running = None


def make_servants(services: Services, cfg: DaemonConfig) -> dict[str, tuple[Any, str]]:
    """Every servant this robot has, by key: (servant, IDL type name)."""
    units = cfg.corba.units
    arms = services.arms.arms
    out: dict[str, tuple[Any, str]] = {
        "spec_a": (SpecAServant(services.spec_a), "IntegratedMotionInterface"),
    }
    for side, family, key in (
        (RightLeft.RIGHT, JARA_RIGHT, "jara_arm"),
        (RightLeft.LEFT, JARA_LEFT, "jara_arm_left"),
    ):
        if side not in arms:
            continue
        si = units.jara_arm == "si"
        out[f"{key}_common"] = (common_servant(family, services, side, si), family.common_type)
        out[f"{key}_middle"] = (middle_servant(family, services, side, si), family.middle_type)
    if set(arms) == {RightLeft.RIGHT, RightLeft.LEFT}:
        si = units.jara_dual == "si"
        out["jara_dual_common"] = (
            DualCommonServant(services),
            "JARA_ARM_DUAL::DualManipulatorCommonInterface_Common",
        )
        out["jara_dual_middle"] = (
            DualMiddleServant(services, si),
            "JARA_ARM_DUAL::DualManipulatorCommonInterface_Middle",
        )
    return out


def start_corba(cfg: DaemonConfig, services: Services, runtime_dir: Path) -> CorbaServer:
    """ORB on ``corba.endpoint``, every servant activated, IOR files written, names bound
    (and re-checked every ``corba.rebind_interval_s``)."""
    global _running
    with _lock:
        if _running is not None:
            raise RuntimeError("a CORBA server already runs in this process (one ORB each)")
        c = cfg.corba
        omninames = start_omninames(c.naming_port, runtime_dir) if c.start_naming_service else None
        try:
            orb = CORBA.ORB_init(
                ["imotion", "-ORBendPoint", c.endpoint, "-ORBclientConnectTimeOutPeriod", "2000"],
                CORBA.ORB_ID,
            )
            poa = orb.resolve_initial_references("RootPOA")
            servants: dict[str, Any] = {}
            refs: dict[str, Any] = {}
            types: dict[str, str] = {}
            for key, (servant, type_name) in make_servants(services, cfg).items():
                poa.activate_object(servant)
                servants[key] = servant
                refs[key] = poa.servant_to_reference(servant)
                types[key] = type_name
            poa._get_the_POAManager().activate()
        except Exception:
            stop_omninames(omninames)
            raise
        server = CorbaServer(orb, poa, servants, refs, types, omninames=omninames)
        _running = server
    if c.ior_dir is not None:
        c.ior_dir.mkdir(parents=True, exist_ok=True)
        for key in refs:
            path = c.ior_dir / f"{key}.ior"
            path.write_text(server.ior(key) + "\n")
            server.ior_files.append(path)
    uri = c.naming_uri()
    if uri is not None:
        names = {key: getattr(c.names, key) for key in refs if getattr(c.names, key) is not None}
        server.naming = NamingBinder(
            orb, uri, {k: (n, refs[k]) for k, n in names.items()}, c.rebind_interval_s
        )
        server.naming.start()
    _log.info(
        "CORBA serving %s on %s%s",
        ", ".join(types[k] for k in refs),
        c.endpoint,
        f", names in {uri}" if uri else "",
    )
    return server


# ------------------------------------------------------------------ omniNames
def omninames_binary() -> Path:
    """The real omniNames binary of the jeteve-omniorb wheel (not its console script)."""
    import jeteve_omniorb

    binary = Path(jeteve_omniorb.__file__).parent / "bin" / "omniNames"
    if binary.is_file():
        return binary
    found = shutil.which("omniNames")
    if found is None:
        raise RuntimeError("omniNames not found: pip install 'imotion[corba]'")
    return Path(found)


def start_omninames(port: int, runtime_dir: Path) -> subprocess.Popen[bytes]:
    """omniNames on 127.0.0.1:``port``, data in ``<runtime_dir>/omninames`` (fresh each
    start); returns once it answers, RuntimeError if it cannot (e.g. the port is taken)."""
    data = runtime_dir / "omninames"
    _stop_leftover(data / "pid")  # a gateway killed outright left its omniNames running
    shutil.rmtree(data, ignore_errors=True)
    data.mkdir(parents=True)
    log = data / "omniNames.log"
    cmd = [
        str(omninames_binary()),
        "-start",
        str(port),
        "-always",
        "-datadir",
        str(data),
        "-errlog",
        str(log),
        "-ORBendPoint",
        f"giop:tcp:127.0.0.1:{port}",
    ]
    proc = subprocess.Popen(
        cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    end = time.monotonic() + OMNINAMES_START_TIMEOUT
    while time.monotonic() < end:
        if proc.poll() is not None:
            text = log.read_text(errors="replace") if log.is_file() else ""
            raise RuntimeError(
                f"omniNames on 127.0.0.1:{port} exited ({proc.returncode}): "
                f"{text.strip().splitlines()[-1] if text.strip() else 'no log'}"
            )
        if log.is_file() and "Checkpointing completed" in log.read_text(errors="replace"):
            (data / "pid").write_text(f"{proc.pid}\n")
            _log.info("omniNames started on 127.0.0.1:%d (pid %d)", port, proc.pid)
            return proc
        time.sleep(0.02)
    stop_omninames(proc)
    raise RuntimeError(f"omniNames on 127.0.0.1:{port} did not start")


def _stop_leftover(pid_file: Path) -> None:
    """Terminate the omniNames a previous gateway of this daemon started (same runtime
    directory), if it still runs."""
    try:
        pid = int(pid_file.read_text())
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
    except (OSError, ValueError):
        return
    if b"omniNames" in cmdline and str(pid_file.parent).encode() in cmdline:
        _log.warning("stopping the omniNames (pid %d) a previous gateway left running", pid)
        os.kill(pid, signal.SIGTERM)
        end = time.monotonic() + 5.0
        while _alive(pid) and time.monotonic() < end:
            time.sleep(0.02)


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rpartition(")")[2].split()[0] != "Z"


def stop_omninames(proc: subprocess.Popen[bytes] | None) -> None:
    if proc is None or proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(2.0)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
