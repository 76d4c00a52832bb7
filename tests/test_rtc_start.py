"""Gateway start-up of the RT component from the daemon configuration (corba.rtc)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("rtctree")

from controller.contract.config import load_config
from controller.gateway.corba.rtc.start import IOR_FILE, start_rtc
from tests import rtc_support as rs


@dataclass
class FakeCorbaServer:
    """What start_rtc reads of a CorbaServer."""

    orb: Any
    poa: Any
    refs: dict[str, Any] = field(default_factory=dict)


@pytest.fixture
def corba(tmp_path: Path) -> FakeCorbaServer:
    orb, poa = rs.orb_and_poa()
    mod, poa_mod = rs.compile_test_idl(tmp_path / "idl")
    ref = poa.id_to_reference(poa.activate_object(rs.probe_servant(mod, poa_mod)))
    return FakeCorbaServer(orb, poa, {"jara_arm_middle": ref, "spec_a": ref})


def test_disabled_component_is_not_created(corba: FakeCorbaServer) -> None:
    cfg = load_config(None, {"corba.enabled": True, "corba.rtc.enabled": False})
    assert start_rtc(cfg, corba) is None


def test_configured_names_rate_and_ior_file(corba: FakeCorbaServer, tmp_path: Path) -> None:
    naming = rs.NamingService(tmp_path / "names")
    cfg = load_config(
        None,
        {
            "corba.enabled": True,
            "corba.naming_service": naming.corbaloc,
            "corba.ior_dir": str(tmp_path / "ior"),
            "corba.rtc.name": "SeedUpperBodyRTC0",
            "corba.rtc.host_context": "h",
            "corba.rtc.ports": {"jara_arm_middle": {"port": "arm", "instance": "mid"}},
            "loop.rate_hz": 800.0,
        },
    )
    (tmp_path / "ior").mkdir()
    comp = start_rtc(cfg, corba)
    assert comp is not None
    try:
        profile = comp.ref.get_component_profile()
        assert profile.instance_name == "SeedUpperBodyRTC0"
        ports = {
            p.name: [(i.instance_name, i.type_name) for i in p.interfaces]
            for p in profile.port_profiles
        }
        assert ports == {
            "SeedUpperBodyRTC0.arm": [("mid", "JARA_ARM::ManipulatorCommonInterface_Middle")],
            "SeedUpperBodyRTC0.IntegratedMotionInterface": [
                ("IntegratedMotionInterface", "IntegratedMotionInterface")
            ],
        }
        assert comp.ref.get_owned_contexts()[0].get_rate() == 800.0
        ior = (tmp_path / "ior" / IOR_FILE).read_text().strip()
        assert corba.orb.string_to_object(ior)._is_equivalent(comp.ref)
        root = rs.naming_root(corba.orb, naming)
        assert rs.resolve(root, "h.host_cxt/SeedUpperBodyRTC0.rtc")._is_equivalent(comp.ref)
    finally:
        comp.close()
        naming.stop()
    assert not (tmp_path / "ior" / IOR_FILE).exists()
