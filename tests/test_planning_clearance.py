"""controller.gateway.planning.clearance: Cartesian moves whose target or path would bring two
bodies (or a body and a static obstacle) closer than the security distance are refused
before anything moves, in every interface family (services without gRPC or a daemon)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from controller.contract.config import load_config
from controller.errors import Refused
from controller.gateway.planning.clearance import ClearanceCheck, combine
from controller.gateway.services.jara_arm import JaraArmService, car_pos
from controller.gateway.services.jara_dual import JaraDualService
from controller.gateway.services.spec_a import SpecAService
from controller.model.kinematics import Kinematics
from controller.model.obstacles import Obstacle, startup_origin
from controller.vocabulary import ReturnCode, RightLeft
from tests.planning_support import context, robot

RIGHT, LEFT = RightLeft.RIGHT, RightLeft.LEFT
#: SmartPal V's closest allowed distance of a planned path [m] (profile: d_s + margin).
CLOSEST = robot("smartpal5").profile.collision_avoidance.planning_distance
WHY = "(closest allowed 20 mm: security distance 5 mm + planning margin 15 mm)"
SPEED, ACCEL = (50.0, 20.0), (100.0, 40.0)
RATES = {"elbow": 20.0, "lumbar_ry": 10.0, "vehicle_translation": 100, "vehicle_rotation": 10}


def hg(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> list[float]:
    """A relative HgMatrix: translation [mm], no rotation."""
    return [1, 0, 0, x, 0, 1, 0, y, 0, 0, 1, z]


#: SmartPal V at home: the right hand 100 mm back and 200 mm towards the body brings the
#: forearm within 16-20 mm of the torso (checked below); 20 mm is allowed. (150 mm straight
#: in no longer does: the checked null space keeps the arm's joints off their limits, and
#: the elbow out.)
INTO_BODY = hg(x=-100, y=200)
BESIDE = hg(y=60)
#: JARA's linear moves keep the elbow angle: the forearm meets the torso later.
INTO_BODY_JARA = hg(x=-150, y=230)


@cache
def hand(side: RightLeft) -> np.ndarray:
    """SmartPal V's control point at home, original frame [m]."""
    kin = Kinematics(robot("smartpal5"))
    kin.update(kin.home())
    return kin.pose(side).translation.copy()


def ball_before(side: RightLeft, ahead: float = 0.1, radius: float = 0.03) -> dict:
    """A ball ``ahead`` [m] in front of ``side``'s hand at home (config form)."""
    pos = hand(side) + np.array([ahead, 0.0, 0.0])
    return {"name": "ball", "type": "sphere", "radius": radius, "pos": pos.tolist()}


def refused(call, *args, **kwargs) -> Refused:
    with pytest.raises(Refused) as err:
        call(*args, **kwargs)
    return err.value


def assert_names_body(comment: str) -> None:
    assert "r_arm_link5 within" in comment and "of lumbar_upper_link" in comment, comment
    assert WHY in comment, comment


# --------------------------------------------------------------------------------- Spec A
@pytest.mark.parametrize("kind", ["linear", "ptp"])
def test_spec_a_cartesian_into_the_body_is_cannot_reach_and_nothing_moves(kind: str) -> None:
    ctx, _, channel = context("smartpal5")
    svc = SpecAService(ctx)
    if kind == "linear":
        err = refused(svc.move_linear, RIGHT, INTO_BODY, SPEED, ACCEL, False, False, "rel_hg_mat")
    else:
        err = refused(svc.move_ptp, RIGHT, INTO_BODY, 3.0, False, True, "rel_hg_mat")
    assert err.code == ReturnCode.CANNOT_REACH_TARGET_ERR
    assert_names_body(err.comment)
    assert "start" not in channel.names()
    # a shorter move the same way keeps its distance: accepted
    if kind == "linear":
        svc.move_linear(RIGHT, BESIDE, SPEED, ACCEL, False, False, "rel_hg_mat")
    else:
        svc.move_ptp(RIGHT, BESIDE, 3.0, False, True, "rel_hg_mat")
    assert channel.names().count("start") == 1


def test_spec_a_linear_into_an_obstacle_names_it() -> None:
    ctx, _, channel = context("smartpal5", obstacles=[ball_before(RIGHT)])
    err = refused(SpecAService(ctx).move_ptp, RIGHT, hg(x=150), 3.0, False, True, "rel_hg_mat")
    assert err.code == ReturnCode.CANNOT_REACH_TARGET_ERR
    assert f"of obstacle:ball {WHY} at " in err.comment, err.comment
    assert err.comment.startswith("the path would bring r_")
    assert "start" not in channel.names()


def test_spec_a_cp_hold_swinging_the_elbow_into_the_body_is_accepted() -> None:
    """Issue 10: a CP-hold pushing the elbow into the body is not refused: it runs and the
    collision rows stop it on its path with a MOTION_BLOCKED warning naming the links
    (tests/test_blocked.py, the demo's step 8)."""
    ctx, _, channel = context("smartpal5")
    SpecAService(ctx).move_cp_hold(RIGHT, {"elbow": 30.0}, RATES, RATES, True)
    assert channel.names().count("start") == 1


# ----------------------------------------------------------------------------------- JARA
@pytest.mark.parametrize("kind", ["linear", "ptp"])
def test_jara_cartesian_into_the_body_is_value_err_and_nothing_moves(kind: str) -> None:
    ctx, _, channel = context("smartpal5")
    svc = JaraArmService(ctx)
    target = car_pos(INTO_BODY_JARA, 0.0, "carPoint")
    move = svc.linear if kind == "linear" else svc.ptp_cartesian
    err = refused(move, RIGHT, target, relative=True, name="carPoint")
    assert err.code == ReturnCode.VALUE_ERR  # JARA has no CANNOT_REACH_TARGET_ERR
    assert_names_body(err.comment)
    assert "start" not in channel.names()


@pytest.mark.parametrize("kind", ["linear", "ptp"])
def test_jara_dual_moves_check_both_arms_together(kind: str) -> None:
    ctx, _, channel = context("smartpal5", obstacles=[ball_before(LEFT)])
    dual = JaraDualService(JaraArmService(ctx))
    forward = car_pos(hg(x=80), 0.0, "x")
    move = dual.move_linear if kind == "linear" else dual.move_ptp_cartesian
    err = refused(move, {RIGHT: car_pos(hg(z=20), 0.0, "x"), LEFT: forward}, relative=True)
    assert err.code == ReturnCode.VALUE_ERR
    assert "would bring l_" in err.comment and "of obstacle:ball" in err.comment, err.comment
    assert "start" not in channel.names()
    up = car_pos(hg(z=20), 0.0, "x")
    move({RIGHT: up, LEFT: up}, relative=True)
    assert channel.names().count("start") == 1


# ------------------------------------------------------------------------ the check itself
@cache
def check(obstacles: tuple[Obstacle, ...] = ()) -> ClearanceCheck:
    return ClearanceCheck(Kinematics(robot("smartpal5")), obstacles)


def test_a_pair_closer_than_d_s_at_the_start_may_move_away_but_not_closer() -> None:
    """A ball about 10 mm in front of the right hand at home (below d_s): moving the hand
    back is accepted, moving it on towards the ball is refused."""
    kin = Kinematics(robot("smartpal5"))
    probe = ClearanceCheck(kin, [Obstacle(**ball_before(RIGHT, ahead=0.1))])
    probe.distances.compute(kin.home())
    gap = ball_gap(probe)
    near = ball_before(RIGHT, ahead=0.1 - (gap - 0.010))
    check_near = ClearanceCheck(kin, [Obstacle(**near)])
    check_near.distances.compute(kin.home())
    assert 0.005 < ball_gap(check_near) < 0.015
    ctx, _, channel = context("smartpal5", obstacles=[near])
    svc = SpecAService(ctx)
    err = refused(svc.move_ptp, RIGHT, hg(x=20), 3.0, False, True, "rel_hg_mat")
    assert "of obstacle:ball" in err.comment
    svc.move_ptp(RIGHT, hg(x=-50), 3.0, False, True, "rel_hg_mat")
    assert channel.names().count("start") == 1


def ball_gap(c: ClearanceCheck) -> float:
    rows = [k for k, (_, b) in enumerate(c.distances.pair_links) if b == "obstacle:ball"]
    return float(c.distances.distances[rows].min())


def test_describe_orders_the_moving_link_first_and_says_into_when_overlapping() -> None:
    c = check()
    c.distances.compute(Kinematics(robot("smartpal5")).home())
    k = next(i for i, p in enumerate(c.distances.pair_links) if p[0] == "lumbar_upper_link")
    c.distances.distances[k] = -0.0123
    text = c.describe(k, "the path", "at 45 % of the path")
    a, b = c.distances.pair_links[k]
    assert text == (f"the path would bring {b} 12.3 mm into {a} {WHY} at 45 % of the path")


def test_joint_line_is_sampled_finely_and_ends_at_the_target() -> None:
    c = check()
    kin = Kinematics(robot("smartpal5"))
    q0 = kin.home()
    q1 = q0.copy()
    q1[kin.index("r_arm_j2")] += 0.35  # the upper arm rolls in, into the body
    reason = c.joint_line_problem(q0, q1)
    assert reason is not None and "of lumbar_upper_link" in reason and "% of the path" in reason
    assert c.joint_line_problem(q0, q0) is None


def test_combine_interpolates_each_arm_at_the_common_path_parameter() -> None:
    q0 = np.zeros(4)
    right = (np.array([0, 1]), [0.0, 0.5, 1.0], [np.zeros(4), np.full(4, 1.0), np.full(4, 2.0)])
    left = (np.array([2, 3]), [0.0, 1.0], [np.zeros(4), np.full(4, 4.0)])
    s, qs = combine(q0, [right, left])
    assert s == [0.0, 0.5, 1.0]
    np.testing.assert_allclose(qs[1], [1, 1, 2, 2])
    np.testing.assert_allclose(qs[2], [2, 2, 4, 4])


def test_obstacles_are_placed_in_the_original_frame_at_start_up() -> None:
    kin = Kinematics(robot("smartpal5"))
    kin.update(kin.home())
    kin.reset_original_frame()  # later re-sets do not move obstacles
    origin = startup_origin(kin.model, kin.robot.profile.body_frame)
    np.testing.assert_allclose(origin.translation, [0, 0, 0.4365], atol=1e-12)


# ------------------------------------------------------------------- docs/collision.md
def docs_example() -> str:
    """The configuration example of docs/collision.md's obstacle section."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "collision.md").read_text()
    section = text[text.index("## Static obstacles") :]
    return section.split("```yaml\n", 1)[1].split("```", 1)[0]


def test_the_documented_obstacle_example_loads_and_refuses_a_move_into_the_table(
    tmp_path: Path,
) -> None:
    path = tmp_path / "imotiond.yaml"
    path.write_text(docs_example())
    cfg = load_config(path)
    assert [o.name for o in cfg.obstacles] == ["table", "floor", "wall", "mast", "lamp"]
    obstacles = [o.model_dump() for o in cfg.obstacles]
    ctx, _, channel = context(cfg.robot, obstacles=obstacles)
    kin = Kinematics(robot(cfg.robot))
    c = ClearanceCheck(kin, cfg.obstacles)
    c.distances.compute(kin.home())
    assert c.distances.distances.min() > CLOSEST  # home is clear of them all
    svc = SpecAService(ctx)
    err = refused(svc.move_ptp, RIGHT, hg(x=60, z=-120), 3.0, False, True, "rel_hg_mat")
    assert f"of obstacle:table {WHY}" in err.comment, err.comment
    assert "start" not in channel.names()
