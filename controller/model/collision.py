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

from controller.model import collision_kernel, jit
from controller.model.collision_kernel import CompiledPairs, Unsupported
from controller.model.collision_shapes import CollisionShape, align_z, collision_shapes
from controller.model.joint_chain import JointChain
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
        shapes: list[tuple[int, int]] = []
        for a, b in link_pairs:
            for i in by_link.get(a, []):
                for k in by_link.get(b, []):
                    self.geometry.addCollisionPair(pin.CollisionPair(i, k))
                    self.pair_links.append((a, b))
                    objs = self.geometry.geometryObjects
                    joints.append((objs[i].parentJoint, objs[k].parentJoint))
                    shapes.append((i, k))
        self._joint_array = np.array(joints, dtype=int).reshape(-1, 2)
        #: Per pair and side, 1.0 on the velocity columns of the joints that move the shape.
        support = self._support_masks(self._joint_array[:, 0])
        support -= self._support_masks(self._joint_array[:, 1])
        #: Per pair, +1 on the velocity columns moving shape 1 only, -1 on those moving
        #: shape 2 only, 0 elsewhere (common ancestors move both alike). Read-only.
        self.support = support
        self.geometry_data = pin.GeometryData(self.geometry)
        for req in self.geometry_data.distanceRequests:
            req.enable_signed_distance = True
            if gjk_tolerance is not None:
                req.gjk_tolerance = gjk_tolerance
        self._own_data = model.createData()
        #: Results of coal, one per pair (references into the geometry data: reading them
        #: through this list is several times faster than through ``distanceResults``).
        self._results = list(self.geometry_data.distanceResults)
        count = len(self.pair_links)
        #: Signed distance of each pair [m] at the last update (negative: overlap); with the
        #: screen on (``kernel.screen``), an upper bound for the pairs beyond reach.
        self.distances = np.zeros(count)
        #: With the compiled kernels: per pair the unit normal from shape 2 to shape 1 and the
        #: witness points on shape 1 and shape 2 (world [m]) at the last update (views of
        #: one array, :attr:`witnesses`, as the kernels take them).
        self.witnesses = np.zeros((count, 3, 3))
        self.normals = self.witnesses[:, 0]
        self.points1 = self.witnesses[:, 1]
        self.points2 = self.witnesses[:, 2]
        self._data: pin.Data = self._own_data
        #: The compiled kernels' model and work arrays (None: coal for every pair, see
        #: :attr:`compiled`).
        self.kernel: CompiledPairs | None = None
        if jit.available():
            try:
                self.kernel = CompiledPairs(model, self.geometry, np.array(shapes))
            except Unsupported:
                self.kernel = None
            else:  # compile (or load from the cache) now, not in a control cycle
                self.compute(pin.neutral(model))
                self.kernel.update_on(
                    pin.neutral(model), self.kernel.chain, self.distances, self.witnesses
                )
                self.jacobian_into(np.zeros(min(count, 1), dtype=np.int64), np.zeros((1, model.nv)))

    @property
    def compiled(self) -> bool:
        """Whether the compiled kernels compute the pairs (numba installed and every joint
        and shape one they handle; ``IMOTION_JIT=0`` turns them off), else coal does."""
        return self.kernel is not None

    @property
    def needs_data(self) -> bool:
        """Whether :meth:`update` reads Pinocchio's data: without the compiled kernels, or
        for box-box pairs (coal computes those)."""
        return self.kernel is None or bool(len(self.kernel.other))

    def _support_masks(self, joints: np.ndarray) -> np.ndarray:
        """``len(joints) x nv``: 1.0 where a velocity moves the joint's frame (0: the world)."""
        model = self.model
        out = np.zeros((len(joints), model.nv))
        for i, joint in enumerate(joints.tolist()):
            for a in model.supports[joint] if joint else []:
                if a:
                    out[i, model.joints[a].idx_v : model.joints[a].idx_v + model.joints[a].nv] = 1
        return out

    def __len__(self) -> int:
        return len(self.pair_links)

    # ---------------------------------------------------------------------------- update
    def compute(self, q: np.ndarray) -> None:
        """Kinematics (own data), then :meth:`update`: for callers without a ``pin.Data``."""
        q = np.asarray(q, dtype=float)
        if self.kernel is None:
            pin.computeJointJacobians(self.model, self._own_data, q)
        elif len(self.kernel.other):
            pin.forwardKinematics(self.model, self._own_data, q)
        self.update(self._own_data, q)

    def update(self, data: pin.Data | None, q: np.ndarray, chain: JointChain | None = None) -> None:
        """Distances of every pair at configuration ``q`` [rad, m].

        ``chain``: a joint chain of this model already placed at ``q`` (the kinematics' own,
        :meth:`~controller.model.kinematics.Kinematics.placed_chain`): with the compiled
        kernels its placements are read, the joints not placed a second time in the cycle.

        ``data`` must be this model's data after ``pin.computeJointJacobians(model, data, q)``
        (what :attr:`controller.model.kinematics.Kinematics.data` gives); without the
        compiled kernels it is kept for :meth:`witness` and :meth:`jacobian`. With them and
        no box-box pair (:attr:`needs_data` False) it is not read and may be None: the kernels
        place the shapes from ``q`` themselves (the control cycle then needs no Pinocchio
        pass).
        """
        compiled = self.kernel
        if data is not None:
            self._data = data
        elif self.needs_data:
            raise ValueError("CollisionDistances.update needs Pinocchio's data here")
        if compiled is None:
            pin.updateGeometryPlacements(self.model, data, self.geometry, self.geometry_data)
            pin.computeDistances(self.geometry, self.geometry_data)
            self.distances[:] = [r.min_distance for r in self._results]
            return
        if chain is not None and compiled.accepts(chain):
            compiled.update_on(q, chain, self.distances, self.witnesses)
        elif chain is not None:
            raise ValueError("CollisionDistances.update: the chain is not of this model")
        else:
            collision_kernel.update(
                q, *compiled.model_arrays, self.distances, self.witnesses, *compiled.screen.arrays
            )
        if len(compiled.other):  # box-box pairs: coal
            pin.updateGeometryPlacements(self.model, data, self.geometry, self.geometry_data)
            for k in compiled.other.tolist():
                res = pin.computeDistance(self.geometry, self.geometry_data, k)
                self.distances[k] = res.min_distance
                self.normals[k] = np.negative(res.normal)
                self.points1[k] = res.getNearestPoint1()
                self.points2[k] = res.getNearestPoint2()

    # -------------------------------------------------------------------------- queries
    def witness(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pair ``k``'s witness points ``p1``, ``p2`` [m] (world) and unit normal ``n`` from
        shape 2 to shape 1, at the last :meth:`update`."""
        if self.kernel is not None:
            return self.points1[k].copy(), self.points2[k].copy(), self.normals[k].copy()
        res = self._results[k]
        p1 = np.array(res.getNearestPoint1())
        p2 = np.array(res.getNearestPoint2())
        return p1, p2, -np.asarray(res.normal)

    def jacobian(self, rows: Sequence[int] | np.ndarray | None = None) -> np.ndarray:
        """Distance Jacobian rows ``n^T (J_p1 - J_p2)`` [m/rad or m/m], ``len(rows) x nv``.

        ``rows``: pair indices (default all). Reads the data of the last :meth:`update`.
        """
        index = np.arange(len(self)) if rows is None else np.asarray(rows, dtype=int)
        out = np.zeros((len(index), self.model.nv))
        self.jacobian_into(index, out)
        return out

    def jacobian_into(self, index: np.ndarray, out: np.ndarray) -> None:
        """:meth:`jacobian` of the pairs ``index`` written into ``out[:len(index)]`` (the
        control cycle's form: no per-row Jacobian fetch, a few array operations).

        With ``(v_O, w)`` the spatial velocity at the world origin of the whole chain (the
        world Jacobian ``data.J`` that ``computeJointJacobians`` leaves), a point ``p`` of a
        link moves at ``v_O + w x p`` through the columns of the link's supporting joints,
        so ``n . p' = n . v_O + (p x n) . w`` over those columns. coal's witness points
        satisfy ``p1 - p2 = d n`` (to rounding), so ``p2 x n = p1 x n``: one row
        ``(n . v_O + (p1 x n) . w)`` masked with (support of shape 1) − (support of shape 2),
        common joints cancelling. Per row two reads from coal, then a few array operations.
        """
        k = len(index)
        if not k:
            return
        if self.kernel is not None:
            self.kernel.rows(index, self.support, self.witnesses, out)
            return
        results = self._results
        got: list[np.ndarray] = []  # normal, p1 of each row (one array at the end)
        for pair in index.tolist():
            r = results[pair]
            got += (r.normal, r.getNearestPoint1())
        vec = np.concatenate(got).reshape(k, 2, 3).transpose(1, 2, 0)  # (vector, axis, row)
        n = np.negative(vec[0])  # (3, k); coal's normal points from shape 1 to shape 2
        p = vec[1]
        # p x n component by component (np.cross costs several times more on small arrays)
        x = np.empty((3, k))
        x[0] = p[1] * n[2] - p[2] * n[1]
        x[1] = p[2] * n[0] - p[0] * n[2]
        x[2] = p[0] * n[1] - p[1] * n[0]
        jac = self._data.J.reshape(6, -1)  # world frame, a view into the data
        rows = out[:k]
        np.dot(n.T, jac[:3], out=rows)
        rows += x.T.dot(jac[3:])
        rows *= self.support[index]

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
        if self.kernel is not None:
            self.kernel.refresh_sizes(self.geometry)

    def closest(self) -> int:
        """Index of the pair with the smallest distance (-1 when no pair is checked); with
        the screen on (:mod:`controller.model.collision_screen`), of the published ones: the
        pairs within reach exact, the others upper bounds."""
        return int(np.argmin(self.distances)) if len(self) else -1
