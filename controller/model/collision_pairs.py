"""Which link pairs imotion checks for self-collision (``config/robots/<id>/collision.yaml``).

Generated, never edited: ``tools/gen_models.py`` samples the joint space (uniformly within the
profile's limits, vehicle axes at 0, grippers included; seeded) and sorts every pair of links
that carry collision shapes into

* ``adjacent``: one link is the nearest shape-carrying ancestor of the other (they touch at
  the joint between them by construction);
* ``rigid``: both ride on the same joint, so their distance never changes;
* ``default``: in collision at a rest pose (zero, or home with the grippers open or closed):
  shapes that overlap by construction where a gripper or a short link meets its neighbours;
* ``always``: in collision in at least :data:`ALWAYS_FRACTION` of the samples;
* ``never``: never closer than ``margin`` [m] in any sample;
* ``checked``: everything else. These are the pairs whose distances the controller computes.

The first four form the allowed-collision list. A test regenerates the file with the stored
seed and sample count and fails when the committed file differs.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import pinocchio as pin
from pydantic import Field

from controller.model.collision import CollisionDistances
from controller.model.collision_shapes import collision_shapes
from controller.model.kinematics import Kinematics
from controller.model.model_source import ModelSource, StrictModel
from controller.model.obstacles import Obstacle, startup_origin
from controller.model.robot import Robot
from controller.model.yaml_source import load_yaml_model

#: Fraction of samples in collision above which a pair counts as always colliding.
ALWAYS_FRACTION = 0.95
#: Defaults of a generated file: samples, seed, margin [m].
DEFAULT_SAMPLES = 20_000
DEFAULT_SEED = 0
DEFAULT_MARGIN = 0.05

Reason = Literal["adjacent", "rigid", "default", "always", "never"]
LinkPair = tuple[str, str]


class CollisionPairs(StrictModel):
    """The contents of ``collision.yaml``."""

    robot: str
    samples: int = Field(gt=0)
    seed: int = Field(ge=0)
    #: Pairs never closer than this in any sample are ``never`` [m].
    margin: float = Field(ge=0)
    checked: tuple[LinkPair, ...]
    allowed: tuple[tuple[str, str, Reason], ...]


def load_collision_pairs(path: Path) -> CollisionPairs:
    """Load and validate a ``collision.yaml``; raises ``ConfigError``."""
    return load_yaml_model(path, CollisionPairs)


def collision_path(robot: Robot) -> Path:
    return robot.directory / "collision.yaml"


def robot_distances(kin: Kinematics, obstacles: Sequence[Obstacle] = ()) -> CollisionDistances:
    """Distances of the robot's checked pairs (``collision.yaml``) and of every moving link
    to the static ``obstacles`` (the daemon configuration's, placed in the original frame
    of start-up), on ``kin``'s model: what the control loop's rows and the planner's
    clearance check both compute."""
    robot = kin.robot
    return CollisionDistances(
        kin.model,
        robot.model,
        load_collision_pairs(collision_path(robot)).checked,
        obstacles=obstacles,
        origin=startup_origin(kin.model, robot.profile.body_frame),
    )


@dataclass(frozen=True)
class _Tree:
    parent: dict[str, str]  # link -> parent link
    order: dict[str, int]  # link -> position in tree order


def _nearest_shaped_ancestor(tree: _Tree, link: str, shaped: set[str]) -> str | None:
    p = tree.parent.get(link)
    while p is not None and p not in shaped:
        p = tree.parent.get(p)
    return p


def classify_pairs(
    source: ModelSource,
    model: pin.Model,
    limits: dict[str, tuple[float, float]],
    samples: int = DEFAULT_SAMPLES,
    seed: int = DEFAULT_SEED,
    margin: float = DEFAULT_MARGIN,
    rest: Sequence[dict[str, float]] = (),
) -> CollisionPairs:
    """Sort every pair of shape-carrying links (see the module docstring).

    ``model``: the full Pinocchio model (from the generated URDF); ``limits``: joint name ->
    (lower, upper) in SI for the joints to sample (others stay at 0); ``rest``: rest poses
    (joint name -> value in SI, others 0) besides the zero pose.
    """
    tree = _Tree(
        {j.child: j.parent for j in source.joints},
        {n: i for i, n in enumerate(source.link_names)},
    )
    shaped = {s.link for s in collision_shapes(source)}
    links = sorted(shaped, key=tree.order.__getitem__)
    joint_of = {n: model.frames[model.getFrameId(n, pin.BODY)].parentJoint for n in links}
    allowed: dict[LinkPair, Reason] = {}
    candidates: list[LinkPair] = []
    for a, b in itertools.combinations(links, 2):
        if _nearest_shaped_ancestor(tree, b, shaped) == a:
            allowed[(a, b)] = "adjacent"
        elif joint_of[a] == joint_of[b]:
            allowed[(a, b)] = "rigid"
        else:
            candidates.append((a, b))

    dist = CollisionDistances(model, source, candidates)
    # shape pairs of one link pair are contiguous rows: reduce each block to its minimum
    starts = np.array([dist.pair_links.index(p) for p in candidates], dtype=int)
    lower = np.zeros(model.nq)
    upper = np.zeros(model.nq)
    for name, (lo, hi) in limits.items():
        if np.isfinite(lo) and np.isfinite(hi) and model.existJointName(name):
            i = model.idx_qs[model.getJointId(name)]
            lower[i], upper[i] = lo, hi
    geo, gdata, data = dist.geometry, dist.geometry_data, model.createData()
    results = list(gdata.distanceResults)  # references: fast to read

    def pair_minimum(q: np.ndarray) -> np.ndarray:
        pin.updateGeometryPlacements(model, data, geo, gdata, q)
        pin.computeDistances(geo, gdata)
        d = np.fromiter((r.min_distance for r in results), float, len(results))
        return np.asarray(np.minimum.reduceat(d, starts))

    at_rest = np.zeros(len(candidates), dtype=bool)
    for pose in [{}, *rest]:
        q = np.zeros(model.nq)
        for name, value in pose.items():
            if model.existJointName(name):
                q[model.idx_qs[model.getJointId(name)]] = value
        at_rest |= pair_minimum(q) <= 0.0
    rng = np.random.default_rng(seed)
    minimum = np.full((samples, len(candidates)), np.inf)
    for s in range(samples):
        minimum[s] = pair_minimum(rng.uniform(lower, upper))
    collided = np.asarray((minimum <= 0.0).mean(axis=0))
    near = np.asarray((minimum < margin).any(axis=0))
    checked: list[LinkPair] = []
    for c, pair in enumerate(candidates):
        if at_rest[c]:
            allowed[pair] = "default"
        elif collided[c] >= ALWAYS_FRACTION:
            allowed[pair] = "always"
        elif not near[c]:
            allowed[pair] = "never"
        else:
            checked.append(pair)
    return CollisionPairs(
        robot=source.robot,
        samples=samples,
        seed=seed,
        margin=margin,
        checked=tuple(checked),
        allowed=tuple((a, b, why) for (a, b), why in allowed.items()),
    )


def rest_poses(robot: Robot) -> list[dict[str, float]]:
    """Home with the grippers open and with them closed, in SI."""
    poses = []
    for which in ("open", "closed"):
        pose = robot.home()
        for gripper in robot.profile.grippers.values():
            for name, value in zip(gripper.joints, getattr(gripper, which), strict=True):
                pose[name] = robot.joints[name].to_si(value)
        poses.append(pose)
    return poses


def render(pairs: CollisionPairs) -> str:
    """The text of ``collision.yaml`` (stable: the staleness test compares it)."""
    lines = [
        f"# {pairs.robot}: self-collision pairs, generated by tools/gen_models.py from model.yaml",
        "# and profile.yaml by sampling the joint space. Do not edit; see docs/collision.md.",
        f"robot: {pairs.robot}",
        f"samples: {pairs.samples}",
        f"seed: {pairs.seed}",
        f"margin: {pairs.margin!r}",
        "checked:" + ("" if pairs.checked else " []"),
        *(f"  - [{a}, {b}]" for a, b in pairs.checked),
        "allowed:" + ("" if pairs.allowed else " []"),
        *(f"  - [{a}, {b}, {why}]" for a, b, why in pairs.allowed),
    ]
    return "\n".join(lines) + "\n"


__all__ = [
    "CollisionPairs",
    "classify_pairs",
    "collision_path",
    "load_collision_pairs",
    "render",
    "rest_poses",
]
