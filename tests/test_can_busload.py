"""hal.can.busload: frame lengths, per-bus load, refuse/warn limits, shipped profiles."""

from __future__ import annotations

import pytest

from config import robot_ids
from hal.can import busload
from hal.can.drive_profile import BusConfig, DriveProfile, drives_path, load_drive_profile
from tests.support import robot


def test_classic_frame_lengths_match_the_worst_case_figures():
    # robots.md: an 8-byte frame takes 111-135 µs at 1 Mbit/s; 135 is the stuffed worst case.
    assert busload.classic_frame_bits(8) == 135
    assert busload.classic_frame_bits(0) == 55
    assert busload.classic_frame_bits(6) == 115
    with pytest.raises(ValueError):
        busload.classic_frame_bits(9)


def test_fd_frames_are_shorter_at_a_higher_data_rate():
    classic = busload.classic_frame_bits(6) / 1e6
    fd = busload.fd_frame_time(6, 1e6, 5e6)
    assert fd < classic
    assert busload.fd_frame_time(12, 1e6, 5e6) > busload.fd_frame_time(8, 1e6, 5e6)


def profile(drives: int, tpdo2: bool = False, fd: bool = False) -> DriveProfile:
    bus = BusConfig(channel="can0", fd=fd, data_bitrate=5_000_000 if fd else None)
    return DriveProfile.model_validate(
        {
            "robot": "x",
            "rate_hz": 500,
            "buses": {"a": bus.model_dump()},
            "drives": {
                f"d{i}": {
                    "bus": "a",
                    "node_id": i + 1,
                    "counts_per_rev": 4096,
                    "velocity_feedback": tpdo2,
                }
                for i in range(drives)
            },
        }
    )


def test_load_of_one_bus():
    load = busload.plan(profile(4), 500)[0]
    # SYNC 55 + 4 × (RPDO 115 + TPDO 115) bits per cycle, + 5 heartbeats/s·10 Hz of 65 bits.
    assert load.cycle_time == pytest.approx(975e-6)
    assert load.load == pytest.approx((975 * 500 + 50 * 65) / 1e6)
    assert load.frames_per_s == pytest.approx(9 * 500 + 50)
    assert busload.plan(profile(4, tpdo2=True), 500)[0].load > load.load
    assert busload.plan(profile(4, fd=True), 500)[0].load < load.load


def test_refuse_over_100_and_warn_over_70():
    with pytest.raises(ValueError, match="over 100 %: refused"):
        busload.check(profile(9), 500)
    _, warning = busload.check(profile(7), 500)
    assert warning and "above 70 %" in warning
    assert busload.check(profile(4), 500)[1] is None


@pytest.mark.parametrize("robot_id", robot_ids())
def test_shipped_profiles_fit_their_planned_rate(robot_id: str):
    r = robot(robot_id)
    p = load_drive_profile(drives_path(r), r)
    loads, warning = busload.check(p, p.rate_hz)
    assert warning is None, warning
    assert busload.worst(loads).load < busload.WARN_ABOVE
    if robot_id == "smartpal5":
        assert p.rate_hz == 500 and len(p.buses) >= 2
    busload.check(p, 500)  # every robot at least runs (maybe with a warning) at 500 Hz
    assert "load" in busload.table_text(p, p.rate_hz)
