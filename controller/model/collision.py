"""Self-collision distances on Pinocchio + coal, with witness-point Jacobians.

:func:`geometry_model` builds a ``pin.GeometryModel`` straight from the collision shapes of
``model.yaml`` (:mod:`controller.model.collision_shapes`): this urdfdom cannot read URDF
capsules, so the URDF's ``<collision>`` elements are for other tools, not for us.

:class:`CollisionDistances` holds the checked shape pairs and, per configuration, their
distances ``d`` [m] (negative when the shapes overlap), witness points ``p1`` on the first
shape and ``p2`` on the second (world frame [m]), the unit normal ``n`` pointing from the
second shape to the first, and the distance Jacobian rows ``J_d = n^T (J_p1 - J_p2)`` with
``ḋ = J_d v`` [m/s], where ``J_p`` is the linear Jacobian of the world point ``p`` moving with
its link (world axes).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import coal
import numpy as np
import pinocchio as pin

from controller.model.collision_shapes import CollisionShape, align_z, collision_shapes
from controller.model.model_source import ModelSource
from controller.model.obstacles import Obstacle, check_unique, is_obstacle


def _geometry(shape: CollisionShape) -> tuple[coal.CollisionGeometry, pin.SE3]:
    """The coal geometry of a shape and its placement in the link frame."""
    if shape.type == "capsule":
        assert shape.p1 is not None and shape.p2 is not None
        axis = (shape.p2 - shape.p1) / shape.length
        return coal.Capsule(shape.radius, shape.length), pin.SE3(align_z(axis), shape.pos)
    if shape.type == "sphere":
        return coal.Sphere(shape.radius), pin.SE3(np.eye(3), shape.pos)
    full = 2.0 * np.asarray(shape.size, dtype=float)
    return coal.Box(*full), pin.SE3(np.eye(3), shape.pos)


def geometry_model(model: pin.Model, source: ModelSource) -> pin.GeometryModel:
    """One geometry object per collision shape, named ``<link>/<index>``, on the link's frame.

    Links missing from ``model`` (none in imotion's models) are skipped.
    """
    gm = pin.GeometryModel()
    count: dict[str, int] = {}
    for shape in collision_shapes(source):
        if not model.existFrame(shape.link, pin.BODY):
            continue
        fid = model.getFrameId(shape.link, pin.BODY)
        frame = model.frames[fid]
        geom, placement = _geometry(shape)
        index = count.get(shape.link, 0)
        count[shape.link] = index + 1
        name = f"{shape.link}/{index}"
        obj = pin.GeometryObject(name, frame.parentJoint, fid, frame.placement * placement, geom)
        gm.addGeometryObject(obj)
    return gm


def _size(geom: coal.CollisionGeometry) -> np.ndarray:
    """A shape's inflatable size: radius of a capsule or sphere, half sides of a box [m]."""
    if isinstance(geom, coal.Box):
        return np.array(geom.halfSide, dtype=float)
    if isinstance(geom, (coal.Capsule, coal.Sphere)):
        return np.array([geom.radius])
    return np.zeros(0)


def link_of(geometry_name: str) -> str:
    """The link of a geometry object named by :func:`geometry_model`."""
    return geometry_name.rsplit("/", 1)[0]


def hand_links(source: ModelSource, flange: str) -> list[str]:
    """The flange link and every link below it (gripper, fingers): where a held object's
    padding goes (:meth:`CollisionDistances.set_padding`)."""
    out, todo = [], [flange]
    while todo:
        link = todo.pop(0)
        out.append(link)
        todo += [j.child for j in source.children(link)]
    return out


class CollisionDistances:
    """Distances, witness points and distance Jacobians of checked link pairs.

    Not thread-safe: one instance per control loop (it owns its geometry data).
    """

    def __init__(
        self,
        model: pin.Model,
        source: ModelSource,
        link_pairs: Iterable[tuple[str, str]],
        gjk_tolerance: float | None = None,
        obstacles: Sequence[Obstacle] = (),
        origin: pin.SE3 | None = None,
    ):
        """``link_pairs``: the link pairs to check (every shape pair of each one becomes a
        row); ``gjk_tolerance``: coal's GJK tolerance for shapes without a closed-form
        distance (boxes) [m] (None: coal's default, 1e-6).

        ``obstacles``: static obstacles (poses in the original frame), fixed in the world at
        ``origin`` (the original frame's pose in the world at start-up,
        ``Kinematics(robot).original_frame``; None: the world frame). Each one is paired with
        every link the joints move (vehicle links included), after the link pairs, named
        ``(link, "obstacle:<name>")`` in :attr:`pair_links`."""
        self.model = model
        self.geometry = geometry_model(model, source)
        check_unique(obstacles)
        moving = [
            link_of(obj.name) for obj in self.geometry.geometryObjects if obj.parentJoint != 0
        ]
        world = pin.SE3.Identity() if origin is None else origin
        for obstacle in obstacles:
            self.geometry.addGeometryObject(
                pin.GeometryObject(
                    f"{obstacle.label}/0", 0, 0, world * obstacle.placement(), obstacle.geometry()
                )
            )
        link_pairs = list(link_pairs)
        for obstacle in obstacles:
            link_pairs += [(link, obstacle.label) for link in dict.fromkeys(moving)]
        by_link: dict[str, list[int]] = {}
        for i, obj in enumerate(self.geometry.geometryObjects):
            by_link.setdefault(link_of(obj.name), []).append(i)
        #: Unpadded size of each shape (see :meth:`set_padding`), by geometry index.
        self._sizes = [_size(obj.geometry) for obj in self.geometry.geometryObjects]
        self._by_link = by_link
        #: Padding [m] of the links :meth:`set_padding` inflated.
        self.padding: dict[str, float] = {}
        #: Link names of each checked shape pair, in row order.
        self.pair_links: list[tuple[str, str]] = []
        #: (joint id of shape 1, joint id of shape 2) per pair.
        joints: list[tuple[int, int]] = []
        for a, b in link_pairs:
            for i in by_link.get(a, []):
                for k in by_link.get(b, []):
                    self.geometry.addCollisionPair(pin.CollisionPair(i, k))
                    self.pair_links.append((a, b))
                    objs = self.geometry.geometryObjects
                    joints.append((objs[i].parentJoint, objs[k].parentJoint))
        self._joint_array = np.array(joints, dtype=int).reshape(-1, 2)
        self.geometry_data = pin.GeometryData(self.geometry)
        for req in self.geometry_data.distanceRequests:
            req.enable_signed_distance = True
            if gjk_tolerance is not None:
                req.gjk_tolerance = gjk_tolerance
        self._own_data = model.createData()
        #: Results of coal, one per pair (references into the geometry data: reading them
        #: through this list is several times faster than through ``distanceResults``).
        self._results = list(self.geometry_data.distanceResults)
        #: Signed distance of each pair [m] at the last update (negative: overlap).
        self.distances = np.zeros(len(self.pair_links))
        self._data: pin.Data = self._own_data

    def __len__(self) -> int:
        return len(self.pair_links)

    # ---------------------------------------------------------------------------- update
    def compute(self, q: np.ndarray) -> None:
        """Kinematics (own data), then :meth:`update`: for callers without a ``pin.Data``."""
        pin.computeJointJacobians(self.model, self._own_data, np.asarray(q, dtype=float))
        self.update(self._own_data)

    def update(self, data: pin.Data) -> None:
        """Distances of every pair at the configuration ``data`` holds.

        ``data`` must be this model's data after ``pin.computeJointJacobians(model, data, q)``
        (which :meth:`controller.model.kinematics.Kinematics.update` does); it is kept for
        :meth:`witness` and :meth:`jacobian`.
        """
        self._data = data
        pin.updateGeometryPlacements(self.model, data, self.geometry, self.geometry_data)
        pin.computeDistances(self.geometry, self.geometry_data)
        self.distances[:] = [r.min_distance for r in self._results]

    # -------------------------------------------------------------------------- queries
    def witness(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pair ``k``'s witness points ``p1``, ``p2`` [m] (world) and unit normal ``n`` from
        shape 2 to shape 1, at the last :meth:`update`."""
        res = self._results[k]
        p1 = np.array(res.getNearestPoint1())
        p2 = np.array(res.getNearestPoint2())
        return p1, p2, -np.asarray(res.normal)

    def jacobian(self, rows: Sequence[int] | np.ndarray | None = None) -> np.ndarray:
        """Distance Jacobian rows ``n^T (J_p1 - J_p2)`` [m/rad or m/m], ``len(rows) x nv``.

        ``rows``: pair indices (default all). Reads the data of the last :meth:`update`.
        Each joint's Jacobian is fetched once; the rows are built in one batch.
        """
        index = np.arange(len(self)) if rows is None else np.asarray(rows, dtype=int)
        out = np.zeros((len(index), self.model.nv))
        if not len(index):
            return out
        picked = [self._results[k] for k in index]
        n = -np.array([r.normal for r in picked])
        for side, sign in ((0, 1.0), (1, -1.0)):
            points = np.array(
                [r.getNearestPoint1() if side == 0 else r.getNearestPoint2() for r in picked]
            )
            joints, inverse = np.unique(self._joint_array[index, side], return_inverse=True)
            jac = np.stack([self._joint_jacobian(int(j)) for j in joints])[inverse]
            origin = np.array([self._data.oMi[int(j)].translation for j in joints])[inverse]
            r = points - origin
            # n . (v + w x r) = n . v + (r x n) . w
            rxn = r[:, [1, 2, 0]] * n[:, [2, 0, 1]] - r[:, [2, 0, 1]] * n[:, [1, 2, 0]]
            out += sign * (
                np.einsum("ki,kin->kn", n, jac[:, :3]) + np.einsum("ki,kin->kn", rxn, jac[:, 3:])
            )
        return out

    def _joint_jacobian(self, joint: int) -> np.ndarray:
        """``6 x nv`` Jacobian of a joint's origin, world axes (zero for the world, 0)."""
        if joint == 0:
            return np.zeros((6, self.model.nv))
        jac = pin.getJointJacobian(self.model, self._data, joint, pin.LOCAL_WORLD_ALIGNED)
        return np.asarray(jac).reshape(6, self.model.nv)  # eigenpy gives (6,) when nv == 1

    # -------------------------------------------------------------------------- padding
    def set_padding(self, links: Iterable[str], radius: float) -> None:
        """Inflate every shape of ``links`` by ``radius`` [m] (0: back to the model's shapes):
        a held object's padding. Capsule and sphere radii grow by ``radius``, box half sides
        too. Takes effect at the next :meth:`update`; the Jacobian rows are unchanged (an
        inflated convex shape's witness point moves along the normal). Not for obstacles."""
        if not math.isfinite(radius) or radius < 0.0:
            raise ValueError(f"padding must be finite and >= 0 m, got {radius!r}")
        objs = self.geometry.geometryObjects
        for link in links:
            if link not in self._by_link or is_obstacle(link):
                raise ValueError(f"{link!r} is not a link with collision shapes")
            for i in self._by_link[link]:
                geom, size = objs[i].geometry, self._sizes[i]
                if isinstance(geom, coal.Box):
                    geom.halfSide = size + radius
                elif len(size):
                    geom.radius = float(size[0] + radius)
            self.padding[link] = float(radius)

    def closest(self) -> int:
        """Index of the pair with the smallest distance (-1 when no pair is checked)."""
        return int(np.argmin(self.distances)) if len(self) else -1
