"""The RT component of a running imotiond (sim hal, CORBA on 127.0.0.1, omniNames on
127.0.0.1): rtshell lists it, rtcon joins its provided port to a consumer component that then
calls through the connection, rtdis parts them; a gateway restart and a naming-service
restart re-register it; the daemon's stop unbinds it."""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import pytest

pytest.importorskip("rtctree")

from rtctree.rtc import RTC, SDOPackage

from controller.corba.stubs import JARA_ARM
from controller.vocabulary import JaraState
from tests import rtc_support as rs
from tests.test_daemon_process import Imotiond, _children

HOST = "testhost"
COMMON_TYPE = "JARA_ARM::ManipulatorCommonInterface_Common"
COMMON_INSTANCE = "JARA_ARM_ManipulatorCommonInterface_Common"  # the jara preset's


@dataclass
class Running:
    naming: rs.NamingService
    daemon: Imotiond

    def path(self, tail: str = "") -> str:
        return f"/{self.naming.address}/{HOST}.host_cxt/{tail}"

    def component(self) -> Any:
        orb, _ = rs.orb_and_poa()
        return rs.resolve(rs.naming_root(orb, self.naming), f"{HOST}.host_cxt/imotion0.rtc")


def start_daemon(naming: rs.NamingService) -> Imotiond:
    daemon = Imotiond(
        *("--hal", "sim", "--listen", "127.0.0.1:0", "--rate", "250"),
        *("--set", "realtime.enabled=false", "--set", "corba.enabled=true"),
        *("--set", f"corba.naming_service={naming.corbaloc}"),
        *("--set", "corba.rebind_interval_s=0.2", "--set", f"corba.rtc.host_context={HOST}"),
        *("--set", "corba.rtc.preset=jara"),
    )
    daemon.wait_ready()
    return daemon


def stop_daemon(daemon: Imotiond) -> None:
    try:
        if daemon.proc.poll() is None:
            daemon.proc.send_signal(signal.SIGTERM)
            assert daemon.wait_exit() == 0, daemon.log
    finally:
        daemon.kill()


@pytest.fixture(scope="module")
def shared(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Running]:
    """One naming service and one daemon for the module (each took 5-8 s to start)."""
    naming = rs.NamingService(tmp_path_factory.mktemp("rtc-daemon"))
    run = Running(naming, start_daemon(naming))
    try:
        yield run
    finally:
        stop_daemon(run.daemon)  # a test may have restarted it
        naming.stop()


@pytest.fixture
def running(shared: Running) -> Running:
    """The module's daemon, running and registered: restarted if a test left it stopped
    (the tests restart the naming service, the gateway and the daemon and leave them
    running; a failed one may not have)."""
    if shared.naming.proc is None or shared.naming.proc.poll() is not None:
        shared.naming.start(shared.naming.port)  # where the daemon looks for it
    if shared.daemon.proc.poll() is not None:
        shared.daemon.kill()
        shared.daemon = start_daemon(shared.naming)
    rs.wait_for(shared.component, what="the component's registration")
    return shared


def test_rtls_and_rtcat_list_the_component_and_its_ports(running: Running) -> None:
    out = rs.rtshell(running.naming, "rtls", "-l", running.path())
    assert next(x for x in out.splitlines() if "imotion0.rtc" in x).split()[0] == "Inactive"
    cat = rs.rtshell(running.naming, "rtcat", "-l", running.path("imotion0.rtc"))
    for port, instance, type_name in (
        ("manipCommon", COMMON_INSTANCE, COMMON_TYPE),
        ("manipMiddle", "JARA_ARM_ManipulatorCommonInterface_Middle", "JARA_ARM::"),
        ("IntegratedMotionInterface", "IntegratedMotionInterface", "IntegratedMotionInterface"),
    ):
        section = cat.split(f"CorbaPort: {port}")[1]
        assert f"Instance name  {instance}" in section and type_name in section, port
    assert "Rate   250.0" in cat


def test_rtcon_connects_a_consumer_which_calls_imotion_through_it(running: Running) -> None:
    orb, poa = rs.orb_and_poa()
    consumer = rs.consumer_component(
        orb,
        poa,
        "app0",
        "common",
        COMMON_TYPE,
        COMMON_INSTANCE,
        JARA_ARM.ManipulatorCommonInterface_Common,
    )
    try:
        rs.bind_consumer(rs.naming_root(orb, running.naming), HOST, consumer)
        theirs = running.path("app0.rtc:common")
        ours = running.path("imotion0.rtc:manipCommon")
        rs.rtshell(running.naming, "rtcon", theirs, ours)
        provider = consumer.port.provider
        assert provider is not None
        result, state = provider.getState()
        assert result.id == JARA_ARM.OK, result.comment
        assert not state & (JaraState.SERVO_ON | JaraState.MOVING)  # nothing was moved
        result, info = provider.getManipInfo()
        assert result.id == JARA_ARM.OK and info.axisNum > 0
        port = next(
            p
            for p in running.component().get_ports()
            if p.get_port_profile().name.endswith(".manipCommon")
        )
        (connector,) = port.get_connector_profiles()
        assert consumer.port.get_connector_profiles()[0].connector_id == connector.connector_id
        rs.rtshell(running.naming, "rtdis", theirs, ours)
        assert port.get_connector_profiles() == []
        assert consumer.port.get_connector_profiles() == []
        assert consumer.port.provider is None
    finally:
        for oid in consumer.oids:
            poa.deactivate_object(oid)


def test_naming_service_restart_rebinds(running: Running) -> None:
    before = running.component()
    running.naming.restart()  # same port, empty: every binding forgotten
    after = rs.wait_for(running.component, what="the rebind after the restart")
    assert after._is_equivalent(before)
    assert "imotion0.rtc" in rs.rtshell(running.naming, "rtls", running.path())


def test_gateway_and_daemon_restarts_register_again_and_stop_unbinds(running: Running) -> None:
    before = running.component()
    (gateway,) = _children(running.daemon.proc.pid)
    os.kill(gateway, signal.SIGKILL)
    running.daemon.wait_line(r"gateway restarted")
    after = rs.wait_for(
        lambda: (c := running.component()) is not None and not c._is_equivalent(before) and c,
        what="the new gateway's component",
    )
    assert after.get_component_profile().instance_name == "imotion0"
    assert "imotion0.rtc" in rs.rtshell(running.naming, "rtls", running.path())
    stop_daemon(running.daemon)
    assert running.component() is None
    running.daemon = start_daemon(running.naming)  # imotiond restarted
    again = rs.wait_for(running.component, what="the restarted daemon's component")
    assert not again._is_equivalent(after)


def test_bad_calls_answer_codes_or_sdo_exceptions_and_the_daemon_stays_up(
    running: Running,
) -> None:
    comp = running.component()
    ec = comp.get_owned_contexts()[0]
    port = comp.get_ports()[0]
    assert comp.attach_context(None) == -1
    assert comp.get_context(-5) is None and comp.get_context(99999) is None
    assert comp.detach_context(12345) == RTC.BAD_PARAMETER
    assert comp.get_context_handle(None) == -1
    assert not comp.is_alive(None)
    assert comp.initialize() == RTC.PRECONDITION_NOT_MET
    assert comp.finalize() == RTC.PRECONDITION_NOT_MET
    for call, exc in (
        (lambda: comp.get_sdo_service(""), SDOPackage.InvalidParameter),
        (lambda: comp.get_service_profile("x"), SDOPackage.InvalidParameter),
        (lambda: comp.get_status("x"), SDOPackage.InvalidParameter),
        (comp.get_monitoring, SDOPackage.InterfaceNotImplemented),
        (
            lambda: comp.get_configuration().remove_configuration_set("default"),
            SDOPackage.NotAvailable,
        ),
        (lambda: comp.get_configuration().get_configuration_set("x"), SDOPackage.InternalError),
    ):
        with pytest.raises(exc):
            call()
    assert ec.set_rate(float("nan")) == RTC.BAD_PARAMETER
    assert ec.set_rate(1e9) == RTC.UNSUPPORTED
    assert ec.add_component(None) == RTC.BAD_PARAMETER
    assert ec.remove_component(None) == RTC.BAD_PARAMETER
    assert ec.activate_component(None) == RTC.BAD_PARAMETER
    assert ec.get_component_state(None) == RTC.CREATED_STATE
    assert port.connect(RTC.ConnectorProfile("x", "", [], []))[0] == RTC.BAD_PARAMETER
    assert port.connect(RTC.ConnectorProfile("x", "", [None, port], []))[0] == RTC.BAD_PARAMETER
    assert port.connect(RTC.ConnectorProfile("x", "", [comp, port], []))[0] != RTC.RTC_OK
    assert port.notify_connect(RTC.ConnectorProfile("x", "i", [], []))[0] == RTC.BAD_PARAMETER
    assert port.disconnect("nope") == RTC.BAD_PARAMETER
    assert port.notify_disconnect("nope") == RTC.BAD_PARAMETER
    assert port.get_connector_profiles() == []
    assert running.daemon.proc.poll() is None
    assert comp.get_component_profile().instance_name == "imotion0"  # still serving
