"""Registration as ``<host>.host_cxt/<name>.rtc``: bind, rebind after a naming-service restart,
replace a stale binding at start, leave a live stranger alone, unbind at close."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("rtctree")

from controller.contract.rtc_config import RtcConfig
from controller.gateway.corba.rtc import ProvidedInterface, RtComponent
from controller.gateway.corba.rtc.naming import NameBinding
from tests import rtc_support as rs

NAME = "h.host_cxt/imotion0.rtc"


@pytest.fixture
def naming(tmp_path: Path) -> Iterator[rs.NamingService]:
    service = rs.NamingService(tmp_path)
    yield service
    service.stop()


@pytest.fixture(scope="module")
def probe_ref(tmp_path_factory: pytest.TempPathFactory) -> Any:
    _, poa = rs.orb_and_poa()
    mod, poa_mod = rs.compile_test_idl(tmp_path_factory.mktemp("idl"))
    return poa.id_to_reference(poa.activate_object(rs.probe_servant(mod, poa_mod)))


def component(probe_ref: Any, **settings: Any) -> RtComponent:
    orb, poa = rs.orb_and_poa()
    cfg = RtcConfig(**{"host_context": "h", **settings})
    provided = [ProvidedInterface("p", "i", rs.PROBE_TYPE, probe_ref)]
    return RtComponent(orb, poa, cfg, provided, 1.0, rebind_interval_s=0.1)


def test_start_binds_under_the_host_context_and_close_unbinds(
    naming: rs.NamingService, probe_ref: Any
) -> None:
    orb, _ = rs.orb_and_poa()
    root = rs.naming_root(orb, naming)
    comp = component(probe_ref)
    comp.start(root)
    assert comp.name_text == NAME
    assert rs.resolve(root, NAME)._is_equivalent(comp.ref)
    comp.close()
    assert rs.resolve(root, NAME) is None
    assert rs.resolve(root, "h.host_cxt") is not None  # other components may live there


def test_host_context_defaults_to_the_host_name(probe_ref: Any) -> None:
    import socket

    comp = component(probe_ref, host_context=None)
    try:
        assert comp.name_text == f"{socket.gethostname()}.host_cxt/imotion0.rtc"
    finally:
        comp.close()


def test_naming_service_restart_rebinds(naming: rs.NamingService, probe_ref: Any) -> None:
    orb, _ = rs.orb_and_poa()
    root = rs.naming_root(orb, naming)
    comp = component(probe_ref)
    comp.start(root)
    try:
        naming.restart()  # same port, no data: every binding forgotten
        found = rs.wait_for(lambda: rs.resolve(root, NAME), what="the rebind")
        assert found._is_equivalent(comp.ref)
        assert comp.binds >= 2
    finally:
        comp.close()


def test_naming_service_down_at_start_binds_when_it_comes(
    naming: rs.NamingService, probe_ref: Any
) -> None:
    orb, _ = rs.orb_and_poa()
    root = rs.naming_root(orb, naming)
    port = naming.port
    naming.stop()
    comp = component(probe_ref)
    comp.start(root)  # logs and retries, never raises
    try:
        assert comp.binds == 0
        naming.start(port)
        rs.wait_for(lambda: rs.resolve(root, NAME), what="the first bind")
    finally:
        comp.close()


def test_a_new_gateway_replaces_the_stale_binding(naming: rs.NamingService, probe_ref: Any) -> None:
    orb, _ = rs.orb_and_poa()
    root = rs.naming_root(orb, naming)
    old = component(probe_ref)
    old.start(root)
    old._binding.close(unbind=False)  # type: ignore[union-attr]  # died without unbinding:
    old._binding = None
    old_ref = old.ref
    old.close()
    assert rs.resolve(root, NAME)._is_equivalent(old_ref)
    new = component(probe_ref)
    new.start(root)
    try:
        assert rs.resolve(root, NAME)._is_equivalent(new.ref)
    finally:
        new.close()


def test_the_watcher_leaves_a_live_strangers_binding(
    naming: rs.NamingService, probe_ref: Any
) -> None:
    orb, _ = rs.orb_and_poa()
    root = rs.naming_root(orb, naming)
    ours = component(probe_ref)
    stranger = component(probe_ref)
    try:
        binding = NameBinding(root, ours.name_path, ours.ref, 3600.0)
        binding.start()
        other = NameBinding(root, ours.name_path, stranger.ref, 3600.0)
        other.start()  # at start: takes the name
        assert not binding.check()  # a live stranger's now: left alone
        assert rs.resolve(root, NAME)._is_equivalent(stranger.ref)
        stranger.close()  # the stranger is gone: its binding is dead
        assert binding.check()
        assert rs.resolve(root, NAME)._is_equivalent(ours.ref)
        binding.close()
        other.close()  # not its name any more: leaves it
        assert rs.resolve(root, NAME) is None
    finally:
        ours.close()


def test_without_a_naming_service_the_component_still_serves(probe_ref: Any) -> None:
    orb, _ = rs.orb_and_poa()
    comp = component(probe_ref)
    try:
        comp.start(None)
        assert comp.binds == 0
        assert comp.ior.startswith("IOR:")
        assert orb.string_to_object(comp.ior).get_sdo_id() == "imotion0"
    finally:
        comp.close()
