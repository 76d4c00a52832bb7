"""Generate ``robot.urdf`` (Pinocchio) and ``robot.xml`` (MJCF, MuJoCo) from one source.

Both files are written from the same :class:`~controller.model.model_source.ModelSource` and
:class:`~controller.model.profile.RobotProfile` (for joint limits), so link frames, joint axes and
inertias are the same numbers in both. ``tools/gen_models.py`` writes them; a test fails when
the committed files differ from what this module generates.

Collision: the shapes of :mod:`controller.model.collision_shapes`. In the URDF each is a
``<collision>`` named ``<link>/<index>``; a capsule is written as a cylinder between its end
points plus a sphere at each end (this urdfdom reads no ``<capsule>``), so tools that read the
URDF see the same swept volume. In the MJCF each is a geom of the same name in group 3
(hidden by default) that collides with nothing by itself (``contype``/``conaffinity`` 0): the
checked pairs of ``collision.yaml`` are listed as explicit ``<contact><pair>`` elements, so
MuJoCo reports contacts between robot geoms exactly for the pairs imotion checks.

Look: each link is drawn as capsules from its origin to its child joints, a short cylinder
along each revolute axis, and the shapes the model lists. Inertia: the model's mass (or
:data:`~controller.model.model_source.DEFAULT_LINK_MASS`) spread as a rod along the link's main
segment: a stand-in for real inertia data, which the public sources do not give.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np
import pinocchio as pin

from controller.model.collision_shapes import CollisionShape, align_z, link_collision_shapes
from controller.model.model_source import DEFAULT_LINK_MASS, Geom, Joint, ModelSource
from controller.model.profile import RobotProfile

#: Limit written to the URDF for unbounded vehicle axes (imotion enforces its own limits).
UNBOUNDED = 1.0e4

PALETTE: dict[str, tuple[float, float, float, float]] = {
    "body": (0.82, 0.83, 0.85, 1.0),
    "dark": (0.25, 0.27, 0.30, 1.0),
    "arm": (0.30, 0.47, 0.70, 1.0),
    "joint": (0.95, 0.62, 0.20, 1.0),
    "gripper": (0.85, 0.35, 0.25, 1.0),
    "wheel": (0.12, 0.12, 0.12, 1.0),
}
DEFAULT_COLOR = "arm"


def num(x: float) -> str:
    """Shortest text that reads back as exactly the same float."""
    v = float(x)
    return "0" if v == 0.0 else repr(v)


def nums(values: np.ndarray | tuple[float, ...] | list[float]) -> str:
    return " ".join(num(v) for v in values)


def rotation(rpy_deg: tuple[float, float, float]) -> np.ndarray:
    """Rotation matrix of URDF roll-pitch-yaw given in [deg]."""
    r, p, y = (math.radians(a) for a in rpy_deg)
    return np.asarray(pin.rpy.rpyToMatrix(r, p, y))


def unit_axis(axis: tuple[float, float, float]) -> np.ndarray:
    a = np.asarray(axis, dtype=float)
    return a / np.linalg.norm(a)


@dataclass(frozen=True)
class Shape:
    """A resolved visual shape in its link frame."""

    type: str
    size: tuple[float, ...]
    pos: np.ndarray
    p1: np.ndarray | None  # capsule/cylinder end points
    p2: np.ndarray | None
    color: str


@dataclass(frozen=True)
class LinkInertia:
    mass: float
    com: np.ndarray
    tensor: np.ndarray  # about the com, link-frame axes


class Exporter:
    """Resolves shapes and inertias once; writes URDF and MJCF text."""

    def __init__(
        self,
        model: ModelSource,
        profile: RobotProfile,
        pairs: tuple[tuple[str, str], ...] = (),
    ):
        self.model = model
        self.profile = profile
        #: Checked link pairs (``collision.yaml``), written as MJCF contact pairs.
        self.pairs = pairs
        self.parent_joint: dict[str, Joint] = {j.child: j for j in model.joints}

    # ----------------------------------------------------------------- shared derivations
    def _radius(self, link: str) -> float:
        r = self.model.link(link).radius
        return self.model.link_radius if r is None else r

    def _segments(self, link: str) -> list[tuple[np.ndarray, np.ndarray]]:
        return [
            (np.zeros(3), np.asarray(j.xyz, dtype=float))
            for j in self.model.children(link)
            if np.linalg.norm(j.xyz) > 1e-6
        ]

    def shapes(self, link: str) -> list[Shape]:
        data = self.model.link(link)
        color = data.color or DEFAULT_COLOR
        r = self._radius(link)
        out: list[Shape] = []
        if r > 0:
            for a, b in self._segments(link):
                out.append(Shape("capsule", (r,), (a + b) / 2, a, b, color))
            pj = self.parent_joint.get(link)
            if pj is not None and pj.type == "revolute":
                ax = unit_axis(pj.axis or (0.0, 0.0, 1.0)) * r
                out.append(Shape("cylinder", (1.15 * r,), np.zeros(3), -ax, ax, "joint"))
        for g in data.geoms:
            out.append(self._shape(g, color))
        return out

    @staticmethod
    def _shape(g: Geom, color: str) -> Shape:
        if g.fromto is not None:
            a, b = np.asarray(g.fromto[:3]), np.asarray(g.fromto[3:])
            return Shape(g.type, g.size, (a + b) / 2, a, b, g.color or color)
        return Shape(g.type, g.size, np.asarray(g.pos, dtype=float), None, None, g.color or color)

    def inertia(self, link: str) -> LinkInertia:
        data = self.model.link(link)
        m = DEFAULT_LINK_MASS if data.mass is None else data.mass
        r = max(self._radius(link), 0.02)
        segments = self._segments(link)
        if segments:
            a, b = max(segments, key=lambda s: float(np.linalg.norm(s[1] - s[0])))
            length = float(np.linalg.norm(b - a))
            d = (b - a) / length
            perp = m * (length**2 / 12.0 + r**2 / 4.0)
            along = m * r**2 / 2.0
            tensor = perp * (np.eye(3) - np.outer(d, d)) + along * np.outer(d, d)
            com_default = (a + b) / 2
        else:
            tensor = 0.4 * m * r**2 * np.eye(3)
            com_default = np.zeros(3)
        com = com_default if data.com is None else np.asarray(data.com, dtype=float)
        return LinkInertia(m, com, tensor)

    def limits(self, joint: Joint) -> tuple[float, float, float] | None:
        """(lower, upper, velocity) in SI, or None for joints the profile does not limit."""
        lim = self.profile.joints.get(joint.name)
        if lim is None:
            return None
        scale = math.radians(1.0) if joint.type == "revolute" else 1.0
        lower = -UNBOUNDED if lim.lower is None else lim.lower * scale
        upper = UNBOUNDED if lim.upper is None else lim.upper * scale
        return lower, upper, lim.velocity * scale

    # ------------------------------------------------------------------------------- URDF
    def urdf(self) -> str:
        m = self.model
        lines = [
            '<?xml version="1.0"?>',
            f"<!-- {m.robot}: generated by tools/gen_models.py from model.yaml and profile.yaml."
            " Do not edit. -->",
            "<!-- Unbounded vehicle axes carry +-1e4 limits here; imotion enforces the profile's."
            " Efforts are not modelled (0). Inertias are stand-ins. -->",
            f"<robot name={quoteattr(m.robot)}>",
        ]
        for name, rgba in PALETTE.items():
            lines.append(f'  <material name="{name}"><color rgba="{nums(rgba)}"/></material>')
        for link in m.link_names:
            lines += self._urdf_link(link)
        for j in m.joints:
            lines += self._urdf_joint(j)
        lines.append("</robot>")
        return "\n".join(lines) + "\n"

    def _urdf_link(self, link: str) -> list[str]:
        out = [f"  <link name={quoteattr(link)}>"]
        if link != self.model.root:
            inert = self.inertia(link)
            t = inert.tensor
            out += [
                "    <inertial>",
                f'      <origin xyz="{nums(inert.com)}" rpy="0 0 0"/>',
                f'      <mass value="{num(inert.mass)}"/>',
                f'      <inertia ixx="{num(t[0, 0])}" ixy="{num(t[0, 1])}" ixz="{num(t[0, 2])}"'
                f' iyy="{num(t[1, 1])}" iyz="{num(t[1, 2])}" izz="{num(t[2, 2])}"/>',
                "    </inertial>",
            ]
        for s in self.shapes(link):
            out += self._urdf_visual(s)
        for i, c in enumerate(link_collision_shapes(self.model, link)):
            out += self._urdf_collision(f"{link}/{i}", c)
        out.append("  </link>")
        return out

    @staticmethod
    def _urdf_visual(s: Shape) -> list[str]:
        rpy = np.zeros(3)
        if s.type == "box":
            geom = f'<box size="{nums(2 * np.asarray(s.size))}"/>'
        elif s.type == "sphere":
            geom = f'<sphere radius="{num(s.size[0])}"/>'
        else:  # capsule and cylinder: a cylinder between the end points
            assert s.p1 is not None and s.p2 is not None
            length = float(np.linalg.norm(s.p2 - s.p1))
            rpy = pin.rpy.matrixToRpy(align_z((s.p2 - s.p1) / length))
            geom = f'<cylinder radius="{num(s.size[0])}" length="{num(length)}"/>'
        return [
            "    <visual>",
            f'      <origin xyz="{nums(s.pos)}" rpy="{nums(rpy)}"/>',
            f"      <geometry>{geom}</geometry>",
            f'      <material name="{s.color}"/>',
            "    </visual>",
        ]

    @staticmethod
    def _urdf_collision(name: str, c: CollisionShape) -> list[str]:
        def element(pos: np.ndarray, rpy: np.ndarray, geom: str) -> list[str]:
            return [
                f"    <collision name={quoteattr(name)}>",
                f'      <origin xyz="{nums(pos)}" rpy="{nums(rpy)}"/>',
                f"      <geometry>{geom}</geometry>",
                "    </collision>",
            ]

        zero = np.zeros(3)
        if c.type == "box":
            return element(c.pos, zero, f'<box size="{nums(2 * np.asarray(c.size))}"/>')
        sphere = f'<sphere radius="{num(c.radius)}"/>'
        if c.type == "sphere":
            return element(c.pos, zero, sphere)
        assert c.p1 is not None and c.p2 is not None
        rpy = np.asarray(pin.rpy.matrixToRpy(align_z((c.p2 - c.p1) / c.length)))
        cylinder = f'<cylinder radius="{num(c.radius)}" length="{num(c.length)}"/>'
        return (
            element(c.pos, rpy, cylinder)
            + element(c.p1, zero, sphere)
            + element(c.p2, zero, sphere)
        )

    def _urdf_joint(self, j: Joint) -> list[str]:
        rpy = [math.radians(a) for a in j.rpy]
        out = [
            f"  <joint name={quoteattr(j.name)} type={quoteattr(j.type)}>",
            f"    <parent link={quoteattr(j.parent)}/>",
            f"    <child link={quoteattr(j.child)}/>",
            f'    <origin xyz="{nums(j.xyz)}" rpy="{nums(rpy)}"/>',
        ]
        if j.type != "fixed":
            assert j.axis is not None
            out.append(f'    <axis xyz="{nums(unit_axis(j.axis))}"/>')
            lim = self.limits(j)
            lower, upper, vel = lim if lim else (-UNBOUNDED, UNBOUNDED, 0.0)
            out.append(
                f'    <limit lower="{num(lower)}" upper="{num(upper)}"'
                f' velocity="{num(vel)}" effort="0"/>'
            )
        out.append("  </joint>")
        return out

    # ------------------------------------------------------------------------------- MJCF
    def mjcf(self) -> str:
        m = self.model
        lines = [
            f"<mujoco model={quoteattr(m.robot)}>",
            f"  <!-- {m.robot}: generated by tools/gen_models.py from model.yaml and"
            " profile.yaml. Do not edit. Inertias are stand-ins. -->",
            '  <compiler angle="radian" autolimits="true"/>',
            '  <option timestep="0.002" integrator="implicitfast"/>',
            "  <visual>",
            '    <global offwidth="1280" offheight="960"/>',
            '    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3" specular="0 0 0"/>',
            "  </visual>",
            "  <asset>",
            '    <texture type="skybox" builtin="gradient" rgb1="0.92 0.94 0.97"'
            ' rgb2="0.70 0.75 0.82" width="256" height="256"/>',
            '    <texture name="grid" type="2d" builtin="checker" rgb1="0.86 0.87 0.88"'
            ' rgb2="0.78 0.79 0.80" width="300" height="300" mark="edge" markrgb="0.6 0.6 0.6"/>',
            '    <material name="grid" texture="grid" texrepeat="8 8" reflectance="0.05"/>',
        ]
        for name, rgba in PALETTE.items():
            lines.append(f'    <material name="{name}" rgba="{nums(rgba)}"/>')
        lines += [
            "  </asset>",
            "  <default>",
            '    <geom contype="0" conaffinity="0"/>',
            '    <default class="collision">',
            '      <geom group="3" rgba="0.9 0.2 0.2 0.4"/>',
            "    </default>",
            "  </default>",
            "  <worldbody>",
            '    <light pos="1 -1 3" dir="-0.3 0.3 -1" directional="true" diffuse="0.7 0.7 0.7"/>',
            '    <geom name="floor" type="plane" size="0 0 0.05" material="grid"/>',
        ]
        lines += self._mjcf_body(m.root, None, 2)
        lines.append("  </worldbody>")
        lines += self._mjcf_pairs()
        lines.append("</mujoco>")
        return "\n".join(lines) + "\n"

    def _mjcf_body(self, link: str, joint: Joint | None, depth: int) -> list[str]:
        pad = "  " * depth
        if joint is None:
            out = [f"{pad}<body name={quoteattr(link)}>"]
        else:
            q = pin.Quaternion(rotation(joint.rpy))
            quat = (q.w, q.x, q.y, q.z)
            out = [
                f"{pad}<body name={quoteattr(link)} pos={quoteattr(nums(joint.xyz))}"
                f" quat={quoteattr(nums(quat))}>"
            ]
        inner = pad + "  "
        if link != self.model.root:
            inert = self.inertia(link)
            t = inert.tensor
            full = (t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2], t[1, 2])
            out.append(
                f'{inner}<inertial pos="{nums(inert.com)}" mass="{num(inert.mass)}"'
                f' fullinertia="{nums(full)}"/>'
            )
        if joint is not None and joint.type != "fixed":
            assert joint.axis is not None
            kind = "hinge" if joint.type == "revolute" else "slide"
            attrs = (
                f'name={quoteattr(joint.name)} type="{kind}" axis="{nums(unit_axis(joint.axis))}"'
            )
            lim = self.profile.joints.get(joint.name)
            if lim is not None and lim.lower is not None:
                lower, upper, _ = self.limits(joint) or (0.0, 0.0, 0.0)
                attrs += f' range="{num(lower)} {num(upper)}"'
            out.append(f"{inner}<joint {attrs}/>")
        for s in self.shapes(link):
            out.append(inner + self._mjcf_geom(s))
        for i, c in enumerate(link_collision_shapes(self.model, link)):
            out.append(inner + self._mjcf_collision(f"{link}/{i}", c))
        for child in self.model.children(link):
            out += self._mjcf_body(child.child, child, depth + 1)
        out.append(f"{pad}</body>")
        return out

    @staticmethod
    def _mjcf_geom(s: Shape) -> str:
        if s.type in ("capsule", "cylinder"):
            assert s.p1 is not None and s.p2 is not None
            place = f'fromto="{nums(np.concatenate([s.p1, s.p2]))}"'
        else:
            place = f'pos="{nums(s.pos)}"'
        return f'<geom type="{s.type}" size="{nums(s.size)}" {place} material="{s.color}"/>'

    @staticmethod
    def _mjcf_collision(name: str, c: CollisionShape) -> str:
        if c.type == "capsule":
            assert c.p1 is not None and c.p2 is not None
            place = f'fromto="{nums(np.concatenate([c.p1, c.p2]))}"'
        else:
            place = f'pos="{nums(c.pos)}"'
        return (
            f'<geom name={quoteattr(name)} class="collision" type="{c.type}"'
            f' size="{nums(c.size)}" {place}/>'
        )

    def _mjcf_pairs(self) -> list[str]:
        counts = {
            link: len(link_collision_shapes(self.model, link)) for link in self.model.link_names
        }
        rows = [
            f'    <pair geom1="{a}/{i}" geom2="{b}/{k}"/>'
            for a, b in self.pairs
            for i in range(counts.get(a, 0))
            for k in range(counts.get(b, 0))
        ]
        return ["  <contact>", *rows, "  </contact>"] if rows else []


def export_urdf(model: ModelSource, profile: RobotProfile) -> str:
    return Exporter(model, profile).urdf()


def export_mjcf(
    model: ModelSource, profile: RobotProfile, pairs: tuple[tuple[str, str], ...] = ()
) -> str:
    """The MJCF text; ``pairs``: the checked link pairs (``collision.yaml``)."""
    return Exporter(model, profile, pairs).mjcf()
