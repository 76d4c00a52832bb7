"""Validation of profile.yaml and model.yaml through controller.model.robot.load_robot."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml

from config import ROBOTS_DIR, robot_ids
from controller.model.robot import load_robot
from controller.model.yaml_source import ConfigError

SHIPPED = ["pa10", "rh", "seednoid", "smartpal5"]

Mutation = Callable[[dict[str, Any]], object]


# ------------------------------------------------------------------------------- helpers
def copy_robot(tmp_path: Path, robot: str) -> Path:
    """A private copy of a shipped robot directory."""
    target = tmp_path / robot
    shutil.copytree(ROBOTS_DIR / robot, target)
    return target


def edit_yaml(path: Path, mutate: Mutation) -> None:
    """Load ``path``, let ``mutate`` change the dict in place, write it back."""
    # The JSON round trip breaks YAML aliases (smartpal5 shares limits between arms), so a
    # mutation touches only the entry it names.
    data = json.loads(json.dumps(yaml.safe_load(path.read_text(encoding="utf-8"))))
    mutate(data)
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")


def broken_profile(tmp_path: Path, robot: str, mutate: Mutation) -> tuple[Path, Path]:
    """(robot dir, profile path) of a copy of ``robot`` whose profile ``mutate`` changed."""
    directory = copy_robot(tmp_path, robot)
    edit_yaml(directory / "profile.yaml", mutate)
    return directory, directory / "profile.yaml"


def broken_model(tmp_path: Path, robot: str, mutate: Mutation) -> tuple[Path, Path]:
    """(robot dir, model path) of a copy of ``robot`` whose model ``mutate`` changed."""
    directory = copy_robot(tmp_path, robot)
    edit_yaml(directory / "model.yaml", mutate)
    return directory, directory / "model.yaml"


def load_error(directory: Path) -> str:
    with pytest.raises(ConfigError) as info:
        load_robot(directory)
    return str(info.value)


def assert_reported(message: str, path: Path, key: str, word: str) -> None:
    """Some line of ``message`` reads ``<path>: <key>: ...`` and contains ``word``."""
    prefix = f"{path}: {key}: "
    lines = [line for line in message.splitlines() if line.startswith(prefix)]
    assert lines, f"no line starts with {prefix!r} in:\n{message}"
    assert any(word in line for line in lines), f"{word!r} not in the {key} line(s):\n{message}"


def joint_index(model: dict[str, Any], name: str) -> int:
    return next(i for i, j in enumerate(model["joints"]) if j["name"] == name)


# ------------------------------------------------------------------------ shipped robots
@pytest.mark.parametrize("robot", SHIPPED)
def test_shipped_robot_loads(robot: str) -> None:
    loaded = load_robot(robot)
    assert loaded.id == robot
    assert loaded.directory == ROBOTS_DIR / robot


def test_shipped_robot_ids_are_the_four_robots() -> None:
    assert robot_ids() == SHIPPED


def test_shipped_robot_loads_from_its_directory() -> None:
    assert load_robot(ROBOTS_DIR / "pa10").id == "pa10"


def test_unknown_robot_id_names_the_shipped_ids() -> None:
    with pytest.raises(ConfigError) as info:
        load_robot("nonexistent")
    message = str(info.value)
    assert "nonexistent" in message
    for robot in SHIPPED:
        assert robot in message


# ------------------------------------------------------------------------ profile breakage
def set_limits(joint: str, **values: object) -> Mutation:
    return lambda d: d["joints"][joint].update(values)


def _set(*keys: str, value: object) -> Mutation:
    """Set ``d[k0][k1]...[kn] = value``."""

    def mutate(d: dict[str, Any]) -> None:
        for k in keys[:-1]:
            d = d[k]
        d[keys[-1]] = value

    return mutate


def _rename_unit_joint(d: dict[str, Any]) -> None:
    d["units"]["RIGHT_ARM"][2] = "J99"


VEHICLE = {
    "type": "differential",
    "wheels": {"kind": "differential", "count": 2, "radius": 0.1, "track": 0.4},
}

PROFILE_BREAKAGES = [
    pytest.param(
        "pa10", set_limits("J2", lower=10, upper=5), "joints.J2", "below", id="lower>upper"
    ),
    pytest.param(
        "pa10", set_limits("J2", lower=5, upper=5), "joints.J2", "below", id="lower=upper"
    ),
    pytest.param(
        "pa10",
        set_limits("J2", velocity=-10),
        "joints.J2.velocity",
        "greater than 0",
        id="negative-velocity",
    ),
    pytest.param(
        "pa10",
        set_limits("J2", velocity=0),
        "joints.J2.velocity",
        "greater than 0",
        id="zero-velocity",
    ),
    pytest.param(
        "pa10",
        set_limits("J3", acceleration=0),
        "joints.J3.acceleration",
        "greater than 0",
        id="zero-acceleration",
    ),
    pytest.param("pa10", _set("speeed", value=1), "speeed", "Extra inputs", id="unknown-key"),
    pytest.param(
        "pa10",
        lambda d: d.pop("body_frame"),
        "body_frame",
        "Field required",
        id="missing-body_frame",
    ),
    pytest.param(
        "pa10",
        _rename_unit_joint,
        "units.RIGHT_ARM[2]",
        "not a moving joint of the model",
        id="unit-joint-not-in-model",
    ),
    pytest.param(
        "pa10",
        _set("home", "J4", value=500),
        "home.J4",
        "outside the limits",
        id="home-outside-limits",
    ),
    pytest.param(
        "pa10", _set("home", "J99", value=5), "home.J99", "not a unit joint", id="home-unknown"
    ),
    pytest.param(
        "pa10",
        _set("grippers", "RIGHT", "open", value=[0.5, 0.03]),
        "grippers.RIGHT.open[0]",
        "outside the limits",
        id="gripper-open-outside-limits",
    ),
    pytest.param(
        "smartpal5",
        _set("redundant_axes", "lumbar", "Ry", "r_arm_j1", value=1),
        "redundant_axes.lumbar.Ry.r_arm_j1",
        "not a LUMBER joint",
        id="lumbar-weight-on-arm-joint",
    ),
    pytest.param(
        "pa10",
        set_limits("J2", lower=None, upper=None),
        "joints.J2",
        "only vehicle axes may be unbounded",
        id="unbounded-arm-joint",
    ),
    pytest.param(
        "pa10",
        set_limits("J2", lower=None),
        "joints.J2",
        "both be numbers or both be null",
        id="half-unbounded",
    ),
    pytest.param(
        "pa10",
        set_limits("J2", velocity="fast"),
        "joints.J2.velocity",
        "valid number",
        id="string-velocity",
    ),
    pytest.param(
        "pa10", _set("home", "J2", value="thirty"), "home.J2", "valid number", id="string-home"
    ),
    pytest.param(
        "pa10",
        _set("redundant_axes", "elbow", "RIGHT", "forward", value=[1, 0, 1]),
        "redundant_axes.elbow.RIGHT",
        "perpendicular",
        id="elbow-not-perpendicular",
    ),
    pytest.param(
        "pa10",
        _set("redundant_axes", "elbow", "RIGHT", "down", value=[0, 0, 0]),
        "redundant_axes.elbow.RIGHT",
        "non-zero",
        id="elbow-zero-direction",
    ),
    pytest.param(
        "smartpal5",
        _set("vehicle", "type", value="hovercraft"),
        "vehicle.type",
        "'omnidirectional' or 'differential'",
        id="vehicle-type",
    ),
    pytest.param(
        "smartpal5",
        lambda d: d.pop("vehicle"),
        "vehicle",
        "VEHICLE unit",
        id="vehicle-unit-without-vehicle",
    ),
    pytest.param(
        "pa10",
        _set("vehicle", value=VEHICLE),
        "vehicle",
        "VEHICLE unit",
        id="vehicle-without-vehicle-unit",
    ),
    pytest.param(
        "pa10",
        _set("arms", "RIGHT", "flange", value="no_such_link"),
        "arms.RIGHT.flange",
        "not a link of the model",
        id="flange-unknown-link",
    ),
    pytest.param(
        "pa10",
        _set("body_frame", value="no_such_link"),
        "body_frame",
        "not a link of the model",
        id="body_frame-unknown-link",
    ),
    pytest.param(
        "pa10",
        _set("units", "LEFT_ARM", value=["J1"]),
        "units.LEFT_ARM[0]",
        "already in unit RIGHT_ARM",
        id="joint-in-two-units",
    ),
    pytest.param(
        "smartpal5",
        _set("vehicle", "workspace", "x", value=[1, 10]),
        "vehicle.workspace",
        "must hold 0",
        id="vehicle-workspace-without-the-origin",
    ),
    pytest.param(
        "smartpal5",
        _set("vehicle", "workspace", "theta", value=[-1e12, 720]),
        "vehicle.workspace",
        "beyond the interfaces' bound",
        id="vehicle-workspace-beyond-the-edge-bound",
    ),
]


def test_every_shipped_vehicle_has_a_bounded_workspace() -> None:
    for robot in robot_ids():
        vehicle = load_robot(robot).profile.vehicle
        if vehicle is not None:
            lo, hi = vehicle.workspace.si()
            assert all(lo < 0) and all(hi > 0) and all(hi - lo < 1e3)


@pytest.mark.parametrize(("robot", "mutate", "key", "word"), PROFILE_BREAKAGES)
def test_broken_profile_names_file_key_and_problem(
    tmp_path: Path, robot: str, mutate: Mutation, key: str, word: str
) -> None:
    directory, profile = broken_profile(tmp_path, robot, mutate)
    assert_reported(load_error(directory), profile, key, word)


def test_unknown_unit_name_is_rejected(tmp_path: Path) -> None:
    directory, profile = broken_profile(tmp_path, "pa10", _set("units", "TORSO", value=["J1"]))
    message = load_error(directory)
    # pydantic reports a bad dict key at location (units, TORSO, "[key]"): only the prefix
    # up to the unit name is pinned here.
    assert message.startswith(f"{profile}: units.TORSO")
    assert "'RIGHT_ARM', 'LEFT_ARM', 'LUMBER' or 'VEHICLE'" in message


def test_elbow_axis_on_six_axis_arm_is_rejected(tmp_path: Path) -> None:
    elbow = {"RIGHT": {"shoulder": "link2", "elbow": "link3", "wrist": "link5"}}
    directory, profile = broken_profile(
        tmp_path, "rh", _set("redundant_axes", value={"elbow": elbow})
    )
    assert_reported(load_error(directory), profile, "redundant_axes.elbow.RIGHT", "7-axis")


def test_elbow_reference_naming_unknown_link_is_rejected(tmp_path: Path) -> None:
    directory, profile = broken_profile(
        tmp_path, "pa10", _set("redundant_axes", "elbow", "RIGHT", "elbow", value="link99")
    )
    message = load_error(directory)
    assert_reported(message, profile, "redundant_axes.elbow.RIGHT.elbow", "link99")


def test_yaml_syntax_error_names_file_and_line(tmp_path: Path) -> None:
    directory = copy_robot(tmp_path, "pa10")
    profile = directory / "profile.yaml"
    profile.write_text("id: pa10\n\tname: PA10-7C\n", encoding="utf-8")
    message = load_error(directory)
    assert message.startswith(str(profile))
    assert "line 2" in message
    assert "syntax" in message


def test_yaml_syntax_error_in_shipped_text_names_its_line(tmp_path: Path) -> None:
    directory = copy_robot(tmp_path, "pa10")
    profile = directory / "profile.yaml"
    lines = profile.read_text(encoding="utf-8").splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("home:"))
    lines[at] = lines[at].removesuffix("}")  # unclosed flow mapping
    profile.write_text("\n".join(lines) + "\n", encoding="utf-8")
    message = load_error(directory)
    assert str(profile) in message
    assert "line" in message


def test_profile_that_is_not_a_mapping_is_rejected(tmp_path: Path) -> None:
    directory = copy_robot(tmp_path, "pa10")
    profile = directory / "profile.yaml"
    profile.write_text("- just\n- a list\n", encoding="utf-8")
    assert_reported(load_error(directory), profile, "<top level>", "mapping")


def test_missing_profile_file_is_rejected(tmp_path: Path) -> None:
    directory = copy_robot(tmp_path, "pa10")
    (directory / "profile.yaml").unlink()
    assert "cannot read" in load_error(directory)


def test_two_cross_check_problems_give_two_lines(tmp_path: Path) -> None:
    def mutate(d: dict[str, Any]) -> None:
        d["home"]["J4"] = 500
        d["arms"]["RIGHT"]["flange"] = "no_such_link"

    directory, profile = broken_profile(tmp_path, "pa10", mutate)
    lines = load_error(directory).splitlines()
    assert len(lines) == 2
    assert all(line.startswith(f"{profile}: ") for line in lines)
    assert_reported("\n".join(lines), profile, "home.J4", "outside the limits")
    assert_reported("\n".join(lines), profile, "arms.RIGHT.flange", "not a link")


def test_two_schema_problems_give_two_lines(tmp_path: Path) -> None:
    def mutate(d: dict[str, Any]) -> None:
        d["joints"]["J1"]["velocity"] = 0
        d["speeed"] = 1

    directory, profile = broken_profile(tmp_path, "pa10", mutate)
    lines = load_error(directory).splitlines()
    assert len(lines) == 2
    assert_reported(lines[0] + "\n" + lines[1], profile, "joints.J1.velocity", "greater than 0")
    assert_reported(lines[0] + "\n" + lines[1], profile, "speeed", "Extra inputs")


# ------------------------------------------------- non-finite and unbounded values
def test_unbounded_gripper_joint_is_a_config_error(tmp_path: Path) -> None:
    directory, profile = broken_profile(
        tmp_path, "pa10", set_limits("hand_left", lower=None, upper=None)
    )
    assert_reported(load_error(directory), profile, "joints.hand_left", "unbounded")


def test_infinite_limits_on_arm_joint_are_rejected(tmp_path: Path) -> None:
    directory, profile = broken_profile(
        tmp_path, "pa10", set_limits("J2", lower=float("-inf"), upper=float("inf"))
    )
    message = load_error(directory)
    assert_reported(message, profile, "joints.J2.lower", "finite")
    assert_reported(message, profile, "joints.J2.upper", "finite")


def test_nan_elbow_direction_is_rejected(tmp_path: Path) -> None:
    directory, profile = broken_profile(
        tmp_path,
        "pa10",
        _set("redundant_axes", "elbow", "RIGHT", "forward", value=[float("nan"), 0, 1]),
    )
    message = load_error(directory)
    assert_reported(message, profile, "redundant_axes.elbow.RIGHT.forward[0]", "finite")


# -------------------------------------------------------------------------- model breakage
def test_model_joint_with_unknown_parent_is_rejected(tmp_path: Path) -> None:
    def mutate(m: dict[str, Any]) -> None:
        m["joints"][joint_index(m, "J3")]["parent"] = "nowhere"

    directory, model = broken_model(tmp_path, "pa10", mutate)
    message = load_error(directory)
    assert message.startswith(f"{model}: ")
    assert "J3" in message
    assert "'nowhere'" in message
    assert "neither the root nor the child" in message


def test_model_duplicated_joint_name_is_rejected(tmp_path: Path) -> None:
    def mutate(m: dict[str, Any]) -> None:
        m["joints"][joint_index(m, "J3")]["name"] = "J2"

    directory, model = broken_model(tmp_path, "pa10", mutate)
    message = load_error(directory)
    assert_reported(message, model, "joints", "unique")
    assert "repeated: J2" in message


def test_model_fixed_joint_with_axis_is_rejected(tmp_path: Path) -> None:
    index = -1

    def mutate(m: dict[str, Any]) -> None:
        nonlocal index
        index = joint_index(m, "flange_joint")
        m["joints"][index]["axis"] = [0, 0, 1]

    directory, model = broken_model(tmp_path, "pa10", mutate)
    assert_reported(load_error(directory), model, f"joints[{index}]", "no axis")


def test_model_moving_joint_without_axis_is_rejected(tmp_path: Path) -> None:
    index = -1

    def mutate(m: dict[str, Any]) -> None:
        nonlocal index
        index = joint_index(m, "J2")
        del m["joints"][index]["axis"]

    directory, model = broken_model(tmp_path, "pa10", mutate)
    assert_reported(load_error(directory), model, f"joints[{index}]", "needs an axis")


def test_model_syntax_error_names_model_file(tmp_path: Path) -> None:
    directory = copy_robot(tmp_path, "rh")
    model = directory / "model.yaml"
    model.write_text("robot: rh\nroot: [ground\n", encoding="utf-8")
    message = load_error(directory)
    assert message.startswith(f"{model}: line ")
