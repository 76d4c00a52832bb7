"""Collision shapes of a robot's links, resolved from ``model.yaml``.

A link's collision shapes are its ``collision`` list when the model gives one (an empty list:
the link never collides). Otherwise they are derived from its look:

* one capsule per ``radius`` segment (link origin to each child joint further than 1 mm), with
  the link's radius (``link_radius`` by default);
* each listed visual geom: a capsule, sphere or box as it is, a cylinder as a capsule of the
  same radius and end points (a capsule is never smaller than the cylinder it replaces).

The joint discs drawn along revolute axes are look only. Every shape is in its link's frame;
lengths [m]. The same shapes feed Pinocchio/coal (:mod:`controller.model.collision`), the
``<collision>`` elements of ``robot.urdf`` and the contact geoms of ``robot.xml``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from controller.model.model_source import CollisionGeom, Geom, ModelSource


@dataclass(frozen=True)
class CollisionShape:
    """One collision shape in its link's frame.

    ``size``: a box's half extents [m], else ``(radius,)`` [m]. A capsule is the segment
    ``p1``-``p2`` [m] swept by its radius; a sphere or box is centred at ``pos`` [m] (a box's
    axes are the link's).
    """

    link: str
    type: str  # "capsule", "sphere" or "box"
    size: tuple[float, ...]
    pos: np.ndarray
    p1: np.ndarray | None = None
    p2: np.ndarray | None = None

    @property
    def radius(self) -> float:
        """Radius [m] of a capsule or sphere (0 for a box)."""
        return 0.0 if self.type == "box" else self.size[0]

    @property
    def length(self) -> float:
        """Length [m] of a capsule's segment (0 for other shapes)."""
        if self.p1 is None or self.p2 is None:
            return 0.0
        return float(np.linalg.norm(self.p2 - self.p1))


def _from_geom(link: str, g: Geom | CollisionGeom) -> CollisionShape:
    if g.fromto is not None:
        a = np.asarray(g.fromto[:3], dtype=float)
        b = np.asarray(g.fromto[3:], dtype=float)
        return CollisionShape(link, "capsule", (g.size[0],), (a + b) / 2, a, b)
    return CollisionShape(link, g.type, tuple(g.size), np.asarray(g.pos, dtype=float))


def link_collision_shapes(model: ModelSource, link: str) -> list[CollisionShape]:
    """The collision shapes of one link (see the module docstring for the rule)."""
    data = model.link(link)
    if data.collision is not None:
        return [_from_geom(link, g) for g in data.collision]
    out: list[CollisionShape] = []
    r = model.link_radius if data.radius is None else data.radius
    if r > 0:
        for j in model.children(link):
            b = np.asarray(j.xyz, dtype=float)
            if np.linalg.norm(b) > 1e-3:
                out.append(CollisionShape(link, "capsule", (r,), b / 2, np.zeros(3), b))
    out += [_from_geom(link, g) for g in data.geoms]
    return out


def collision_shapes(model: ModelSource) -> list[CollisionShape]:
    """Every collision shape of the robot, links in tree order."""
    return [s for link in model.link_names for s in link_collision_shapes(model, link)]


def align_z(direction: np.ndarray) -> np.ndarray:
    """A rotation matrix whose z axis is the unit vector ``direction``."""
    z = direction
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])
