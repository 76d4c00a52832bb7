"""The kinematic source of a robot (``config/robots/<id>/model.yaml``).

One file per robot describes its kinematic tree: links with their inertia and look, joints with
their placement and axis. ``robot.urdf`` (for Pinocchio) and ``robot.xml`` (MJCF, for MuJoCo)
are both generated from it by :mod:`controller.model.model_export`, so the two can never disagree.

Units in the file: lengths [m], angles (``rpy``) [deg], masses [kg]. Every link frame is
placed by its parent joint's ``xyz``/``rpy``; authored models keep link frames parallel to the
robot base at the zero pose (rpy = 0) except where a frame convention needs otherwise
(flanges: z along the approach direction).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from controller.model.yaml_source import load_yaml_model

Vec3 = tuple[float, float, float]
Positive = Annotated[float, Field(gt=0)]

#: Mass [kg] given to links the model names no mass for (virtual links such as the vehicle's
#: x and y stages). MuJoCo requires every moving body to have mass; both exports use this value.
DEFAULT_LINK_MASS = 0.01


class StrictModel(BaseModel):
    """Base for config schemas: unknown keys are errors, numbers finite, values immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Geom(StrictModel):
    """A visual shape in its link's frame (also used for the link's stand-in inertia)."""

    type: Literal["box", "sphere", "capsule", "cylinder"]
    #: box: half extents [m] (3 values); sphere, capsule, cylinder: radius [m] (1 value).
    size: tuple[Positive, ...]
    #: Centre of a box or sphere [m].
    pos: Vec3 = (0.0, 0.0, 0.0)
    #: End points of a capsule or cylinder [m]: x1 y1 z1 x2 y2 z2.
    fromto: tuple[float, float, float, float, float, float] | None = None
    color: str | None = None

    @model_validator(mode="after")
    def _check_shape(self) -> Geom:
        want = 3 if self.type == "box" else 1
        if len(self.size) != want:
            raise ValueError(f"a {self.type} takes {want} size value(s), got {len(self.size)}")
        if self.type in ("capsule", "cylinder") and self.fromto is None:
            raise ValueError(f"a {self.type} needs 'fromto' (two end points)")
        return self


class CollisionGeom(StrictModel):
    """A collision shape in its link's frame: a capsule or sphere (a box where neither fits)."""

    type: Literal["capsule", "sphere", "box"]
    #: box: half extents [m] (3 values); sphere, capsule: radius [m] (1 value).
    size: tuple[Positive, ...]
    #: Centre of a box or sphere [m].
    pos: Vec3 = (0.0, 0.0, 0.0)
    #: End points of a capsule's segment [m]: x1 y1 z1 x2 y2 z2 (distinct points).
    fromto: tuple[float, float, float, float, float, float] | None = None

    @model_validator(mode="after")
    def _check_shape(self) -> CollisionGeom:
        want = 3 if self.type == "box" else 1
        if len(self.size) != want:
            raise ValueError(f"a {self.type} takes {want} size value(s), got {len(self.size)}")
        if self.type == "capsule":
            if self.fromto is None:
                raise ValueError("a capsule needs 'fromto' (two end points)")
            a, b = np.asarray(self.fromto[:3]), np.asarray(self.fromto[3:])
            if float(np.linalg.norm(b - a)) < 1e-6:
                raise ValueError("a capsule's end points must differ (use a sphere)")
        elif self.fromto is not None:
            raise ValueError(f"a {self.type} is placed by 'pos', not 'fromto'")
        return self


class Link(StrictModel):
    """Inertia and look of one link."""

    #: Mass [kg]; links without one get :data:`DEFAULT_LINK_MASS`.
    mass: Positive | None = None
    #: Centre of mass in the link frame [m]; default: centre of the link's main segment.
    com: Vec3 | None = None
    #: Radius [m] of the capsules drawn from the link origin to its child joints (0: none).
    radius: Annotated[float, Field(ge=0)] | None = None
    geoms: tuple[Geom, ...] = ()
    color: str | None = None
    #: Collision shapes. Unset: derived from the look (see :mod:`controller.model.collision`):
    #: the ``radius`` capsules, plus each listed geom (a cylinder as a capsule of the same
    #: radius and end points). An empty list: the link never collides.
    collision: tuple[CollisionGeom, ...] | None = None


class Joint(StrictModel):
    """A joint: placement of ``child`` in ``parent`` and, unless fixed, its axis."""

    name: str
    type: Literal["revolute", "prismatic", "fixed"]
    parent: str
    child: str
    #: Translation of the child frame in the parent frame [m].
    xyz: Vec3 = (0.0, 0.0, 0.0)
    #: Roll, pitch, yaw of the child frame in the parent frame [deg] (URDF convention).
    rpy: Vec3 = (0.0, 0.0, 0.0)
    #: Axis in the child frame (normalised on export); required unless fixed.
    axis: Vec3 | None = None

    @model_validator(mode="after")
    def _check_axis(self) -> Joint:
        if self.type == "fixed":
            if self.axis is not None:
                raise ValueError("a fixed joint has no axis")
        elif self.axis is None:
            raise ValueError(f"a {self.type} joint needs an axis")
        elif float(np.linalg.norm(self.axis)) < 1e-9:
            raise ValueError("axis must not be the zero vector")
        return self


class ModelSource(StrictModel):
    """The whole kinematic tree of one robot."""

    robot: str
    #: Name of the root link (world-fixed; the vehicle's planar joints hang below it).
    root: str
    #: Default capsule radius [m] for links that do not set their own.
    link_radius: Positive = 0.04
    links: dict[str, Link] = Field(default_factory=dict)
    #: Joints in tree order: every parent is the root or the child of an earlier joint.
    joints: tuple[Joint, ...]

    @field_validator("joints")
    @classmethod
    def _check_unique(cls, joints: tuple[Joint, ...]) -> tuple[Joint, ...]:
        names = [j.name for j in joints]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"joint names must be unique; repeated: {', '.join(dup)}")
        children = [j.child for j in joints]
        dup = sorted({n for n in children if children.count(n) > 1})
        if dup:
            raise ValueError(f"a link can have only one parent joint; repeated child: {dup}")
        return joints

    @model_validator(mode="after")
    def _check_tree(self) -> ModelSource:
        known = {self.root}
        for i, j in enumerate(self.joints):
            if j.parent not in known:
                raise ValueError(
                    f"joints[{i}] ({j.name}): parent link {j.parent!r} is neither the root nor "
                    "the child of an earlier joint"
                )
            if j.child == self.root:
                raise ValueError(f"joints[{i}] ({j.name}): the root link cannot be a child")
            known.add(j.child)
        unknown = sorted(set(self.links) - known)
        if unknown:
            raise ValueError(f"links not in the tree: {', '.join(unknown)}")
        return self

    @property
    def link_names(self) -> list[str]:
        """Root first, then every child in tree order."""
        return [self.root, *(j.child for j in self.joints)]

    def link(self, name: str) -> Link:
        """The link's data (an empty :class:`Link` where the model lists none)."""
        return self.links.get(name, Link())

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    def children(self, link: str) -> list[Joint]:
        return [j for j in self.joints if j.parent == link]


def load_model_source(path: Path) -> ModelSource:
    """Load and validate a ``model.yaml``.

    Raises :class:`~controller.model.yaml_source.ConfigError`.
    """
    return load_yaml_model(path, ModelSource)
