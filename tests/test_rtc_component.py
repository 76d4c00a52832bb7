"""The RT component object, its execution context and SDO configuration, called over CORBA."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

pytest.importorskip("rtctree")

from omniORB import CORBA
from omniORB import any as corba_any
from rtctree.rtc import RTC, SDOPackage

from controller.contract.rtc_config import RtcConfig
from controller.gateway.corba.rtc import ProvidedInterface, RtComponent
from controller.gateway.corba.rtc.nvlist import nv_find
from tests import rtc_support as rs


@pytest.fixture
def comp(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RtComponent]:
    orb, poa = rs.orb_and_poa()
    mod, poa_mod = rs.compile_test_idl(tmp_path_factory.mktemp("idl"))
    ref = poa.id_to_reference(poa.activate_object(rs.probe_servant(mod, poa_mod)))
    settings = RtcConfig(name="arm7", type_name="ArmRTC", host_context="h")
    provided = [ProvidedInterface("manipMiddle", "JARA_ARM_Probe", rs.PROBE_TYPE, ref)]
    component = RtComponent(orb, poa, settings, provided, 500.0)
    yield component
    component.close()


def test_profile(comp: RtComponent) -> None:
    profile = comp.ref.get_component_profile()
    assert (profile.instance_name, profile.type_name, profile.category) == (
        "arm7",
        "ArmRTC",
        "Manipulator",
    )
    assert profile.parent is None
    assert [p.name for p in profile.port_profiles] == ["arm7.manipMiddle"]
    assert nv_find(profile.properties, "exec_cxt.periodic.rate") == "500.0"
    assert nv_find(profile.properties, "naming.names") == "h.host_cxt/arm7.rtc"
    assert comp.ref.get_sdo_id() == "arm7"
    assert comp.ref.get_device_profile().model == "ArmRTC"


def test_owned_context_is_periodic_at_the_control_rate(comp: RtComponent) -> None:
    owned = comp.ref.get_owned_contexts()
    assert len(owned) == 1
    ec = owned[0]
    assert comp.ref.get_context_handle(ec) == 0
    assert comp.ref.get_context(0)._is_equivalent(ec)
    assert comp.ref.get_context(5) is None
    assert comp.ref.is_alive(ec)
    assert comp.ref.get_participating_contexts() == []
    assert ec.get_kind() == RTC.PERIODIC
    assert ec.get_rate() == 500.0
    assert ec.is_running()
    profile = ec.get_profile()
    assert profile.owner._is_equivalent(comp.ref) and profile.rate == 500.0
    assert ec.set_rate(500.0) == RTC.RTC_OK
    assert ec.set_rate(100.0) == RTC.UNSUPPORTED
    assert ec.set_rate(-1.0) == RTC.BAD_PARAMETER
    assert ec.set_rate(float("nan")) == RTC.BAD_PARAMETER
    assert ec.start() == RTC.PRECONDITION_NOT_MET
    assert ec.stop() == RTC.RTC_OK and not ec.is_running()
    assert ec.start() == RTC.RTC_OK


def test_life_cycle_state_is_bookkeeping(comp: RtComponent) -> None:
    ec = comp.ref.get_owned_contexts()[0]
    me = comp.ref
    assert ec.get_component_state(me) == RTC.INACTIVE_STATE
    assert ec.deactivate_component(me) == RTC.PRECONDITION_NOT_MET
    assert ec.reset_component(me) == RTC.PRECONDITION_NOT_MET
    assert ec.activate_component(me) == RTC.RTC_OK
    assert ec.get_component_state(me) == RTC.ACTIVE_STATE
    assert ec.activate_component(me) == RTC.PRECONDITION_NOT_MET
    assert ec.deactivate_component(me) == RTC.RTC_OK
    assert ec.get_component_state(me) == RTC.INACTIVE_STATE


def test_other_components_are_not_participants(comp: RtComponent) -> None:
    orb, poa = rs.orb_and_poa()
    other = rs.consumer_component(orb, poa, "x", "p", "A::B", "i", None)
    ec = comp.ref.get_owned_contexts()[0]
    try:
        assert ec.activate_component(other.ref) == RTC.BAD_PARAMETER
        assert ec.get_component_state(other.ref) == RTC.CREATED_STATE
        assert ec.add_component(other.ref) == RTC.UNSUPPORTED
        assert ec.add_component(comp.ref) == RTC.PRECONDITION_NOT_MET
        assert ec.add_component(None) == RTC.BAD_PARAMETER
        assert ec.remove_component(comp.ref) == RTC.PRECONDITION_NOT_MET
        assert ec.remove_component(other.ref) == RTC.BAD_PARAMETER
        # Another component's context attached to ours: handle 1000, detach frees it.
        theirs = other.ref.get_owned_contexts()[0]
        assert comp.ref.attach_context(theirs) == 1000
        assert comp.ref.get_participating_contexts()[0]._is_equivalent(theirs)
        assert comp.ref.get_context_handle(theirs) == 1000
        assert comp.ref.is_alive(theirs)
        assert comp.ref.detach_context(1000) == RTC.RTC_OK
        assert comp.ref.detach_context(1000) == RTC.BAD_PARAMETER
        assert comp.ref.detach_context(0) == RTC.BAD_PARAMETER
        assert not comp.ref.is_alive(theirs)
        assert comp.ref.attach_context(None) == -1
    finally:
        for oid in other.oids:
            poa.deactivate_object(oid)


def test_actions_answer_ok(comp: RtComponent) -> None:
    me = comp.ref
    assert me.on_initialize() == RTC.RTC_OK and me.on_finalize() == RTC.RTC_OK
    for action in (
        me.on_startup,
        me.on_shutdown,
        me.on_activated,
        me.on_deactivated,
        me.on_aborting,
        me.on_error,
        me.on_reset,
        me.on_execute,
        me.on_state_update,
        me.on_rate_changed,
    ):
        assert action(0) == RTC.RTC_OK
    assert me.initialize() == RTC.PRECONDITION_NOT_MET
    assert me.finalize() == RTC.PRECONDITION_NOT_MET


def test_unsupported_sdo_operations_raise_sdo_exceptions(comp: RtComponent) -> None:
    me = comp.ref
    assert me.get_owned_organizations() == [] and me.get_organizations() == []
    assert me.get_service_profiles() == [] and me.get_status_list() == []
    for call, exc in (
        (lambda: me.get_service_profile("x"), SDOPackage.InvalidParameter),
        (lambda: me.get_sdo_service("x"), SDOPackage.InvalidParameter),
        (lambda: me.get_status("x"), SDOPackage.InvalidParameter),
        (me.get_monitoring, SDOPackage.InterfaceNotImplemented),
    ):
        with pytest.raises(exc) as info:
            call()
        assert info.value.description


def test_configuration_is_read_only(comp: RtComponent) -> None:
    conf = comp.ref.get_configuration()
    sets = conf.get_configuration_sets()
    assert [s.id for s in sets] == ["default"]
    assert conf.get_active_configuration_set().id == "default"
    assert nv_find(sets[0].configuration_data, "preset") == "seed_noid"
    value = conf.get_configuration_parameter_value("rate_hz")
    assert corba_any.from_any(value) == "500.0"
    with pytest.raises(SDOPackage.InvalidParameter):
        conf.get_configuration_parameter_value("nope")
    with pytest.raises(SDOPackage.InternalError):
        conf.get_configuration_set("nope")
    assert conf.activate_configuration_set("default")
    with pytest.raises(SDOPackage.NotAvailable) as info:
        conf.set_configuration_set_values(sets[0])
    assert "read-only" in info.value.description
    with pytest.raises(SDOPackage.NotAvailable):
        conf.set_configuration_parameter("preset", corba_any.to_any("jara"))
    with pytest.raises(SDOPackage.NotAvailable):
        conf.add_organization(None)
    profile = SDOPackage.ServiceProfile("id", "IDL:x:1.0", [], None)
    assert conf.add_service_profile(profile) is False
    assert conf.remove_service_profile("id") is False


def test_exit_withdraws_the_component_only(tmp_path_factory: pytest.TempPathFactory) -> None:
    orb, poa = rs.orb_and_poa()
    naming = rs.NamingService(tmp_path_factory.mktemp("names"))
    try:
        mod, poa_mod = rs.compile_test_idl(tmp_path_factory.mktemp("idl"))
        servant = rs.probe_servant(mod, poa_mod)
        ref = poa.id_to_reference(poa.activate_object(servant))
        provided = [ProvidedInterface("p", "i", rs.PROBE_TYPE, ref)]
        comp = RtComponent(orb, poa, RtcConfig(host_context="h"), provided, 100.0)
        root = rs.naming_root(orb, naming)
        comp.start(root)
        assert rs.resolve(root, "h.host_cxt/imotion0.rtc")._is_equivalent(comp.ref)
        ec = comp.ref.get_owned_contexts()[0]
        ec.activate_component(comp.ref)
        assert comp.ref.exit() == RTC.RTC_OK
        assert rs.resolve(root, "h.host_cxt/imotion0.rtc") is None
        assert ec.get_component_state(comp.ref) == RTC.INACTIVE_STATE
        assert not comp.ref.is_alive(ec)
        assert comp.ref.exit() == RTC.RTC_OK
        assert comp.ref.finalize() == RTC.RTC_OK
        assert ref._narrow(mod.Probe).getState()[1] == 7  # the service itself stays
        comp.close()
        with pytest.raises(CORBA.OBJECT_NOT_EXIST):
            comp.ref.get_sdo_id()
    finally:
        naming.stop()
