"""rtshell (rtls, rtcat, rtcon, rtdis, rtact, rtdeact, rtconf, rtexit) against the component,
as subprocesses on 127.0.0.1, with an OpenRTM-style consumer component beside it."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import pytest

pytest.importorskip("rtctree")

from rtctree.rtc import RTC

from controller.contract.rtc_config import RtcConfig
from controller.gateway.corba.rtc import ProvidedInterface, RtComponent
from tests import rtc_support as rs

INSTANCE = "JARA_ARM_ManipulatorCommonInterface_Middle"


@dataclass
class Setup:
    naming: rs.NamingService
    comp: RtComponent
    consumer: rs.Consumer

    def path(self, name: str) -> str:
        return f"/{self.naming.address}/h.host_cxt/{name}"


@pytest.fixture(scope="module")
def setup(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Setup]:
    orb, poa = rs.orb_and_poa()
    naming = rs.NamingService(tmp_path_factory.mktemp("names"))
    mod, poa_mod = rs.compile_test_idl(tmp_path_factory.mktemp("idl"))
    ref = poa.id_to_reference(poa.activate_object(rs.probe_servant(mod, poa_mod)))
    settings = RtcConfig(host_context="h", preset="jara")
    provided = [ProvidedInterface("manipMiddle", INSTANCE, rs.PROBE_TYPE, ref)]
    comp = RtComponent(orb, poa, settings, provided, 500.0)
    root = rs.naming_root(orb, naming)
    comp.start(root)
    consumer = rs.consumer_component(
        orb, poa, "client0", "middle", rs.PROBE_TYPE, INSTANCE, mod.Probe
    )
    rs.bind_consumer(root, "h", consumer)
    yield Setup(naming, comp, consumer)
    comp.close()
    naming.stop()


def test_rtls_lists_the_component(setup: Setup) -> None:
    out = rs.rtshell(setup.naming, "rtls", "-l", setup.path(""))
    line = next(x for x in out.splitlines() if "imotion0.rtc" in x)
    assert line.split()[0] == "Inactive"
    assert "client0.rtc" in out


def test_rtcat_shows_the_profile_context_and_port(setup: Setup) -> None:
    out = rs.rtshell(setup.naming, "rtcat", "-l", setup.path("imotion0.rtc"))
    for text in (
        "imotion0.rtc",
        "Type name      imotion",
        "Kind   Periodic",
        "Rate   500.0",
        "CorbaPort: manipMiddle",
        f"Instance name  {INSTANCE}",
        f"Type name      {rs.PROBE_TYPE}",
        "Polarity       Provided",
    ):
        assert text in out, text
    port = rs.rtshell(setup.naming, "rtcat", setup.path("imotion0.rtc:manipMiddle"))
    assert "CorbaPort: manipMiddle" in port


def test_rtcon_connects_a_consumer_that_then_calls_through(setup: Setup) -> None:
    provider = setup.path("imotion0.rtc:manipMiddle")
    consumer = setup.path("client0.rtc:middle")
    rs.rtshell(setup.naming, "rtcon", consumer, provider)
    assert setup.consumer.port.provider is not None
    result, state = setup.consumer.port.provider.getState()
    assert (result.id, state) == (0, 7)
    mine = setup.comp.ports[0].ref
    assert len(mine.get_connector_profiles()) == 1
    assert len(setup.consumer.port.get_connector_profiles()) == 1
    out = rs.rtshell(setup.naming, "rtcat", "-l", provider)
    assert "client0.rtc:middle" in out
    rs.rtshell(setup.naming, "rtdis", consumer, provider)
    assert mine.get_connector_profiles() == []
    assert setup.consumer.port.get_connector_profiles() == []
    assert setup.consumer.port.provider is None


def test_rtact_and_rtdeact_change_the_state_only(setup: Setup) -> None:
    ec = setup.comp.context
    rs.rtshell(setup.naming, "rtact", setup.path("imotion0.rtc"))
    assert ec.state == RTC.ACTIVE_STATE
    out = rs.rtshell(setup.naming, "rtls", "-l", setup.path(""))
    assert next(x for x in out.splitlines() if "imotion0" in x).split()[0] == "Active"
    rs.rtshell(setup.naming, "rtdeact", setup.path("imotion0.rtc"))
    assert ec.state == RTC.INACTIVE_STATE


def test_rtconf_lists_the_read_only_settings(setup: Setup) -> None:
    out = rs.rtshell(setup.naming, "rtconf", setup.path("imotion0.rtc"), "list", "-l")
    assert "default" in out and "jara" in out and "500.0" in out
    refused = rs.rtshell(
        setup.naming, "rtconf", setup.path("imotion0.rtc"), "set", "preset", "x", check=False
    )
    assert "read-only" in refused or "NotAvailable" in refused


def test_exit_through_rtctree_withdraws_the_component(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    # rtshell-aist 4.2.10's rtexit imports OpenRTM's top-level RTC module (not installable
    # here): the same call through rtctree, as rtexit makes it.
    orb, poa = rs.orb_and_poa()
    naming = rs.NamingService(tmp_path_factory.mktemp("names"))
    try:
        comp = RtComponent(orb, poa, RtcConfig(name="gone0", host_context="h"), [], 100.0)
        comp.start(rs.naming_root(orb, naming))
        listing = f"/{naming.address}/h.host_cxt/"
        assert "gone0.rtc" in rs.rtshell(naming, "rtls", listing)
        script = (
            "import sys; from rtctree.tree import RTCTree; from rtctree.path import parse_path; "
            "p = parse_path(sys.argv[1])[0]; t = RTCTree(paths=p); t.get_node(p).exit()"
        )
        rs.rtshell(naming, "python", "-c", script, listing + "gone0.rtc")
        assert "gone0.rtc" not in rs.rtshell(naming, "rtls", listing)
        comp.close()
    finally:
        naming.stop()
