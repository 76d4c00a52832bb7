"""CorbaPort service ports: OpenRTM's connect / notify protocol, with a consumer component."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip("rtctree")

from rtctree.rtc import RTC

from controller.contract.rtc_config import RtcConfig
from controller.gateway.corba.rtc import ProvidedInterface, RtComponent
from controller.gateway.corba.rtc.nvlist import nv, nv_find
from tests import rtc_support as rs

INSTANCE = "JARA_ARM_Probe"


@pytest.fixture(scope="module")
def probe(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Any, Any]]:
    _orb, poa = rs.orb_and_poa()
    mod, poa_mod = rs.compile_test_idl(tmp_path_factory.mktemp("idl"))
    ref = poa.id_to_reference(poa.activate_object(rs.probe_servant(mod, poa_mod)))
    yield mod, ref


@pytest.fixture
def parts(probe: tuple[Any, Any]) -> Iterator[tuple[RtComponent, rs.Consumer, Any]]:
    mod, ref = probe
    orb, poa = rs.orb_and_poa()
    provided = [
        ProvidedInterface("arm", INSTANCE, rs.PROBE_TYPE, ref),
        ProvidedInterface("arm", "second", rs.PROBE_TYPE, ref),
        ProvidedInterface("other", "other", "Other::Iface", ref),
    ]
    comp = RtComponent(orb, poa, RtcConfig(host_context="h"), provided, 250.0)
    consumer = rs.consumer_component(orb, poa, "cons0", "in", rs.PROBE_TYPE, INSTANCE, mod.Probe)
    yield comp, consumer, mod
    comp.close()
    for oid in consumer.oids:
        poa.deactivate_object(oid)


def connect(first: Any, ports: list[Any], props: list[Any] | None = None) -> tuple[Any, Any]:
    profile = RTC.ConnectorProfile("c", "", ports, props or [])
    return first.connect(profile)


def test_port_profile_lists_one_interface_per_provided_object(parts: Any) -> None:
    comp, _, _ = parts
    arm = comp.ports[0].ref.get_port_profile()
    assert arm.name == "imotion0.arm"
    assert nv_find(arm.properties, "port.port_type") == "CorbaPort"
    assert [(i.instance_name, i.type_name, i.polarity) for i in arm.interfaces] == [
        (INSTANCE, rs.PROBE_TYPE, RTC.PROVIDED),
        ("second", rs.PROBE_TYPE, RTC.PROVIDED),
    ]
    assert arm.owner._is_equivalent(comp.ref)
    assert arm.port_ref._is_equivalent(comp.ports[0].ref)
    assert [p.get_port_profile().name for p in comp.ref.get_ports()] == [
        "imotion0.arm",
        "imotion0.other",
    ]


@pytest.mark.parametrize("consumer_first", [True, False])
def test_connect_publishes_the_iors_and_the_consumer_calls_through(
    parts: Any, consumer_first: bool
) -> None:
    comp, consumer, _ = parts
    mine, theirs = comp.ports[0].ref, consumer.port.ref
    ports = [theirs, mine] if consumer_first else [mine, theirs]
    ret, profile = connect(ports[0], ports)
    assert ret == RTC.RTC_OK
    assert profile.connector_id
    for key in (
        f"imotion0.port.arm.provided.{rs.PROBE_TYPE}.{INSTANCE}",
        f"port.{rs.PROBE_TYPE}.{INSTANCE}",
        f"port.{rs.PROBE_TYPE}.second",
    ):
        assert (nv_find(profile.properties, key) or "").startswith("IOR:"), key
    assert consumer.port.provider is not None
    assert consumer.port.provider.getState()[1] == 7  # a call through the connection
    for port in (mine, theirs):
        assert [c.connector_id for c in port.get_connector_profiles()] == [profile.connector_id]
    got = mine.get_connector_profile(profile.connector_id)
    assert got.name == "c" and len(got.ports) == 2
    assert mine.get_port_profile().connector_profiles[0].connector_id == profile.connector_id


@pytest.mark.parametrize("side", ["provider", "consumer"])
def test_disconnect_from_either_side_forgets_the_connection(parts: Any, side: str) -> None:
    comp, consumer, _ = parts
    mine, theirs = comp.ports[0].ref, consumer.port.ref
    _, profile = connect(theirs, [theirs, mine])
    port = mine if side == "provider" else theirs
    assert port.disconnect(profile.connector_id) == RTC.RTC_OK
    assert mine.get_connector_profiles() == []
    assert theirs.get_connector_profiles() == []
    assert consumer.port.provider is None
    assert mine.disconnect(profile.connector_id) == RTC.BAD_PARAMETER
    assert mine.notify_disconnect("nope") == RTC.BAD_PARAMETER
    assert mine.get_connector_profile("nope").connector_id == ""


def test_a_second_connection_between_the_same_ports_is_refused(parts: Any) -> None:
    comp, consumer, _ = parts
    mine, theirs = comp.ports[0].ref, consumer.port.ref
    assert connect(mine, [mine, theirs])[0] == RTC.RTC_OK
    ret, _ = connect(mine, [mine, theirs])
    assert ret == RTC.PRECONDITION_NOT_MET
    assert len(mine.get_connector_profiles()) == 1
    dup = [nv("dataport.allow_dup_connection", "YES")]
    assert connect(mine, [mine, theirs], dup)[0] == RTC.RTC_OK
    assert len(mine.get_connector_profiles()) == 2
    assert mine.disconnect_all() == RTC.RTC_OK
    assert mine.get_connector_profiles() == [] and theirs.get_connector_profiles() == []


def test_an_existing_connector_id_is_refused(parts: Any) -> None:
    comp, consumer, _ = parts
    mine, theirs = comp.ports[0].ref, consumer.port.ref
    _, profile = connect(mine, [mine, theirs])
    again = RTC.ConnectorProfile("again", profile.connector_id, [mine, theirs], [])
    assert mine.connect(again)[0] == RTC.PRECONDITION_NOT_MET


def test_bad_profiles_answer_a_code(parts: Any) -> None:
    comp, _, _ = parts
    mine = comp.ports[0].ref
    assert mine.connect(RTC.ConnectorProfile("x", "", [], []))[0] == RTC.BAD_PARAMETER
    assert mine.connect(RTC.ConnectorProfile("x", "", [None], []))[0] == RTC.BAD_PARAMETER
    # A profile that does not contain this port: notify_connect cannot forward it.
    other = comp.ports[1].ref
    ret, _ = mine.notify_connect(RTC.ConnectorProfile("x", "id1", [other], []))
    assert ret == RTC.BAD_PARAMETER
    assert mine.notify_connect(RTC.ConnectorProfile("x", "id2", [], []))[0] == RTC.BAD_PARAMETER
    assert mine.get_connector_profiles() == []  # nothing kept of a profile it is not in


def test_a_vanished_peer_is_dropped_on_read(parts: Any) -> None:
    comp, consumer, _ = parts
    _, poa = rs.orb_and_poa()
    mine, theirs = comp.ports[0].ref, consumer.port.ref
    connect(mine, [mine, theirs])
    poa.deactivate_object(consumer.oids[3])  # the consumer's port object is gone
    consumer.oids.remove(consumer.oids[3])
    assert mine.get_connector_profiles() == []


def test_two_interfaces_with_one_instance_name_on_a_port_are_refused(
    probe: tuple[Any, Any],
) -> None:
    _, ref = probe
    orb, poa = rs.orb_and_poa()
    twice = [
        ProvidedInterface("p", "same", "A::B", ref),
        ProvidedInterface("p", "same", "A::C", ref),
    ]
    with pytest.raises(ValueError, match="same"):
        RtComponent(orb, poa, RtcConfig(), twice, 100.0)


def test_a_profile_naming_a_non_port_object_answers_a_code(parts: Any, probe: Any) -> None:
    comp, _, _ = parts
    _, probe_ref = probe
    mine = comp.ports[0].ref
    ret, _ = mine.connect(RTC.ConnectorProfile("x", "", [probe_ref, mine], []))
    assert ret == RTC.BAD_PARAMETER
    ret, _ = mine.connect(RTC.ConnectorProfile("x", "", [mine, probe_ref], []))
    assert ret != RTC.RTC_OK
    assert mine.get_connector_profiles() == []


def test_concurrent_connects_and_disconnects_keep_the_list_consistent(parts: Any) -> None:
    comp, consumer, _ = parts
    mine, theirs = comp.ports[0].ref, consumer.port.ref
    dup = [nv("dataport.allow_dup_connection", "YES")]
    errors: list[BaseException] = []

    def work() -> None:
        try:
            for _ in range(10):
                ret, profile = connect(mine, [mine, theirs], dup)
                assert ret == RTC.RTC_OK
                assert mine.disconnect(profile.connector_id) == RTC.RTC_OK
        except BaseException as exc:  # reported below
            errors.append(exc)

    threads = [threading.Thread(target=work) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert mine.get_connector_profiles() == []
    assert theirs.get_connector_profiles() == []
