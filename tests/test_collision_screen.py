"""controller.model.collision_screen: which pairs an update computes, and why that is safe."""

from __future__ import annotations

import math

import numpy as np
import pytest

from controller.model import jit
from controller.model.collision import CollisionDistances
from controller.model.collision_pairs import robot_distances
from controller.model.collision_screen import MAX_STALE, PairScreen, shape_extent
from controller.model.kinematics import Kinematics
from controller.qp.constraints.collision import CollisionAvoidance
from controller.qp.constraints.protocol import CycleState, RowBlock
from tests.support import OBSTACLES, SHAPED_ROBOTS, kinematics

pytestmark = pytest.mark.skipif(not jit.available(), reason="numba not installed")

ROBOTS = SHAPED_ROBOTS
WITHIN, HORIZON = 0.05, 250.0


def screen_of(dist: CollisionDistances) -> PairScreen:
    assert dist.kernel is not None
    return dist.kernel.screen


def path(kin: Kinematics, seed: int, steps: int, speed: float) -> list[np.ndarray]:
    """A smooth joint path from home: each joint a sine of its own frequency and phase,
    amplitude 0.6 rad (0.3 m for prismatic ones), ``speed`` scaling the frequencies [1/step]."""
    rng = np.random.default_rng(seed)
    freq = rng.uniform(0.5, 1.5, kin.nv) * speed
    phase = rng.uniform(0, math.tau, kin.nv)
    home = kin.home()
    return [home + 0.6 * (np.sin(freq * t + phase) - np.sin(phase)) for t in range(steps)]


def test_shape_extents() -> None:
    frame = np.zeros((4, 3))
    frame[:3] = np.eye(3)
    frame[3] = (0.3, 0.4, 0.0)  # centre 0.5 m from the joint
    capsule = np.array([0.05, 0.1, 0, 0])  # radius, half length along z
    assert shape_extent(0, frame, capsule) == pytest.approx(math.hypot(0.5, 0.1) + 0.05)
    box = np.array([0.1, 0.2, 0.2, 0])
    assert shape_extent(1, frame, box) == pytest.approx(0.5 + 0.3)
    assert shape_extent(2, frame, np.zeros(4)) == math.inf


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_the_levers_bound_how_far_every_pair_moves(robot_id: str) -> None:
    """|d(q1) − d(q0)| ≤ Σ_j lever_kj·|q1_j − q0_j| for every pair a lever bounds, for small
    and large steps from random configurations (the robot's pairs and obstacles of every
    kind): the bound the screening stands on."""
    kin = kinematics(robot_id)
    dist = robot_distances(kin, OBSTACLES)
    screen = screen_of(dist)
    assert not screen.enabled  # off by default: every pair exact
    rng = np.random.default_rng(3)
    tight = 0
    for trial in range(60):
        q0 = rng.uniform(-1.5, 1.5, kin.nv)
        q1 = q0 + rng.normal(scale=(0.005, 0.05, 0.5)[trial % 3], size=kin.nv)
        dist.compute(q0)
        d0 = dist.distances.copy()
        dist.compute(q1)
        change = np.abs(dist.distances - d0)
        dq = np.abs(q1 - q0)
        for k in np.flatnonzero(~screen.exact).tolist():
            entries = slice(screen.start[k], screen.start[k + 1])
            bound = float(screen.lever[entries].dot(dq[screen.column[entries]]))
            assert change[k] <= bound + 1e-9, (k, dist.pair_links[k], change[k], bound)
            tight += change[k] > 0.2 * bound
    assert tight  # the bounds are not vacuous


@pytest.mark.parametrize("robot_id", ROBOTS)
def test_a_screened_pair_is_beyond_reach_and_its_distance_an_upper_bound(robot_id: str) -> None:
    """Along smooth paths, updates with the screen on against every pair computed: the
    computed pairs equal to the last bit; each screened pair is truly beyond ``within``, even
    with its closing speed over the look-ahead, and its published distance is above the
    true one by at most 2·MAX_STALE. Most pairs are screened most of the time."""
    kin = kinematics(robot_id)
    screened, every = robot_distances(kin, OBSTACLES), robot_distances(kin, OBSTACLES)
    screen = screen_of(screened)
    screen.set(WITHIN, HORIZON)
    n = len(screened)
    counts, returned = [], 0
    for seed, speed in ((1, 0.0005), (2, 0.002)):
        last = None
        was_screened = np.zeros(n, dtype=bool)
        for q in path(kin, seed, 1000, speed):
            screened.compute(q)
            every.compute(q)
            computed = screen.computed.copy()
            if seed == 1:  # joints up to 0.3 rad/s (0.3 m/s) at 1 kHz, all at once
                counts.append(int(computed.sum()))
            np.testing.assert_array_equal(screened.distances[computed], every.distances[computed])
            np.testing.assert_array_equal(screened.witnesses[computed], every.witnesses[computed])
            true, published = every.distances[~computed], screened.distances[~computed]
            assert (true >= WITHIN).all()
            assert (published >= true - 1e-12).all()
            assert (published - true <= 2 * MAX_STALE + 1e-12).all()
            if last is not None:  # the rows' key: the distance less its closing speed ahead
                closing = np.maximum(last - every.distances, 0.0)
                assert (every.distances - closing * HORIZON >= WITHIN)[~computed].all()
            returned += int((computed & was_screened).sum())
            was_screened = ~computed
            last = every.distances.copy()
    assert np.median(counts) < n / 2  # the screen leaves most pairs out
    assert returned  # and pairs came back into the computed set on the way


def test_off_and_a_padding_compute_every_pair_at_the_next_update() -> None:
    kin = kinematics("smartpal5")
    dist = robot_distances(kin)
    screen = screen_of(dist)
    with pytest.raises(ValueError, match="screening needs"):
        screen.set(math.inf, 10.0)
    with pytest.raises(ValueError, match="screening needs"):
        screen.set(0.05, -1.0)
    screen.set(WITHIN, HORIZON)
    q = kin.home()
    dist.update(None, q)
    dist.update(None, q)
    assert screen.enabled and screen.computed.sum() < len(dist)
    dist.set_padding(["r_arm_link7"] if "r_arm_link7" in dist._by_link else [], 0.05)
    dist.update(None, q)
    assert screen.computed.all()  # the levers anew: every pair exact once
    dist.update(None, q)
    assert not screen.computed.all()
    screen.off()
    dist.update(None, q)
    assert not screen.enabled and screen.computed.all()


def test_the_rows_take_every_pair_they_take_without_the_screen() -> None:
    """The collision rows over the screened distances (the screen set by the rows from their
    influence distance and look-ahead) against rows over distances computed in full, along
    paths that bring pairs into range and out: the screened rows' pairs in range include the
    others' at every cycle (a pair that comes back from the screen brings a closing speed at
    least its true one), and the rows of the pairs both have agree."""
    kin = kinematics("smartpal5")
    settings = kin.robot.profile.collision_avoidance
    dt = 0.001
    rows = [
        CollisionAvoidance(kin, robot_distances(kin), settings, dt),
        CollisionAvoidance(kin, robot_distances(kin), settings, dt),
    ]
    full = screen_of(rows[1].distances)
    full.set = lambda *args, **kwargs: None  # type: ignore[method-assign]
    full.off()  # (the rows set it when built)
    nv, m = kin.nv, rows[0].max_rows
    blocks = [RowBlock(np.zeros((m, nv)), np.zeros(m), np.zeros(m)) for _ in rows]
    in_range = extra = 0
    for q in path(kin, 4, 1500, 0.004):
        kin.update(q)
        for r, block in zip(rows, blocks, strict=True):
            r.distances.update(None, kin.q, kin.placed_chain())
            r.compute_qp_inequalities(CycleState(kin, kin.q, np.zeros(nv), None, None), block)
        assert screen_of(rows[0].distances).enabled and not full.enabled
        mine, theirs = set(rows[0].pairs.tolist()), set(rows[1].pairs.tolist())
        assert theirs <= mine or len(mine) == m
        in_range += bool(theirs)
        extra += len(mine - theirs)
    assert in_range  # the path brought pairs into range
    # A pair back from the screen is taken for at most the cycle it comes back in (its
    # closing bounded by its step): rarely, and never crowding the rows out.
    assert extra <= 0.01 * in_range, (extra, in_range)  # 0 here; 739 without the cap
