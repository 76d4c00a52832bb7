"""Static obstacles: world-fixed shapes the robot must keep away from (a table, a wall, a mast).

Declared in the daemon configuration (``obstacles:``, :class:`controller.contract.config.
DaemonConfig`), each one is a box, a sphere, a capsule or a plane (a half-space) placed in the
**original frame as set at start-up** (the body origin at the zero configuration, the frame
Cartesian targets are given in): position ``pos`` [m] and roll-pitch-yaw ``rpy`` [rad] (URDF
convention: ``R = Rz(yaw) Ry(pitch) Rx(roll)``). Obstacles stay where they are when the
vehicle moves or the original frame is re-set later.

Shapes in the obstacle's own frame:

* ``box``: ``half_extents`` [m] along its x, y, z, centred on ``pos``;
* ``sphere``: ``radius`` [m] centred on ``pos``;
* ``capsule``: ``radius`` [m] around a segment of ``length`` [m] along its z, centred on ``pos``;
* ``plane``: the surface through ``pos`` normal to its z; the obstacle is everything on the
  −z side, so z points into free space (a floor: ``rpy: [0, 0, 0]``; a wall beyond x = 1 m
  facing the robot: ``pos: [1, 0, 0]``, ``rpy: [0, -1.5708, 0]``).

:class:`controller.model.collision.CollisionDistances` pairs every obstacle with every link
the joints can move (vehicle links included); the pairs are named ``(link, "obstacle:<name>")``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from controller.model.model_source import StrictModel, Vec3

if TYPE_CHECKING:  # coal and Pinocchio load at first use: the configuration (imotiond
    # --check, the CLI) validates obstacles without them (~0.5 s of imports)
    import coal
    import pinocchio as pin

Positive = Annotated[float, Field(gt=0)]

#: Prefix of an obstacle's name in ``CollisionDistances.pair_links``.
OBSTACLE_PREFIX = "obstacle:"

_NEEDS: dict[str, set[str]] = {
    "box": {"half_extents"},
    "sphere": {"radius"},
    "capsule": {"radius", "length"},
    "plane": set(),
}


class Obstacle(StrictModel):
    """One static obstacle (see the module docstring for the frame and the shapes)."""

    #: Named in refusals and damper rows as ``obstacle:<name>``.
    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$", max_length=64)
    type: Literal["box", "sphere", "capsule", "plane"]
    #: Position in the original frame [m].
    pos: Vec3 = (0.0, 0.0, 0.0)
    #: Orientation in the original frame: roll, pitch, yaw [rad].
    rpy: Vec3 = (0.0, 0.0, 0.0)
    #: A box's half extents along its own axes [m].
    half_extents: tuple[Positive, Positive, Positive] | None = None
    #: A sphere's or capsule's radius [m].
    radius: Positive | None = None
    #: A capsule's segment length along its own z [m].
    length: Positive | None = None

    @model_validator(mode="after")
    def _check_shape(self) -> Obstacle:
        needs = _NEEDS[self.type]
        given = {k for k in ("half_extents", "radius", "length") if getattr(self, k) is not None}
        if needs - given:
            raise ValueError(f"a {self.type} needs {', '.join(sorted(needs - given))}")
        if given - needs:
            raise ValueError(f"a {self.type} takes no {', '.join(sorted(given - needs))}")
        return self

    def placement(self) -> pin.SE3:
        """Pose of the obstacle's frame in the original frame."""
        import pinocchio as pin

        return pin.SE3(pin.rpy.rpyToMatrix(*self.rpy), np.asarray(self.pos, dtype=float))

    def geometry(self) -> coal.CollisionGeometry:
        """The coal shape in the obstacle's own frame."""
        import coal

        if self.type == "box":
            assert self.half_extents is not None
            return coal.Box(*(2.0 * np.asarray(self.half_extents, dtype=float)))
        if self.type == "sphere":
            assert self.radius is not None
            return coal.Sphere(self.radius)
        if self.type == "capsule":
            assert self.radius is not None and self.length is not None
            return coal.Capsule(self.radius, self.length)
        return coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)

    @property
    def label(self) -> str:
        """``obstacle:<name>``, as in ``CollisionDistances.pair_links``."""
        return OBSTACLE_PREFIX + self.name


def check_unique(obstacles: Sequence[Obstacle]) -> None:
    """ValueError when two obstacles share a name."""
    seen: set[str] = set()
    for obstacle in obstacles:
        if obstacle.name in seen:
            raise ValueError(f"two obstacles are named {obstacle.name!r}")
        seen.add(obstacle.name)


def startup_origin(model: pin.Model, body_frame: str) -> pin.SE3:
    """The original frame as set at start-up, in the world: the pose of the body frame
    (the profile's ``body_frame``) at the zero configuration. Obstacles are given in it
    (``CollisionDistances(..., origin=startup_origin(kin.model, robot.profile.body_frame))``)."""
    import pinocchio as pin

    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    return data.oMf[model.getFrameId(body_frame, pin.BODY)].copy()


def is_obstacle(name: str) -> bool:
    """Whether a ``pair_links`` entry names an obstacle."""
    return name.startswith(OBSTACLE_PREFIX)


__all__ = ["OBSTACLE_PREFIX", "Obstacle", "check_unique", "is_obstacle", "startup_origin"]
