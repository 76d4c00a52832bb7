"""Render the robot client-side in MuJoCo from streamed joint positions (Monitor.StreamState).

A StateSample carries unit joint positions in API units (deg; vehicle x, y in mm and θ in
deg in the original frame). :class:`FrameRenderer` converts them to SI, puts them on the MJCF
joints of the robot and draws one image per sample, with the control points (the streamed
poses, original frame) and optional line segments (a commanded straight line) marked.
Reuses ``tools/render_robots.py``. The vehicle joints equal the vehicle pose in the original
frame as long as nobody calls resetOriginalFrame (the demo does not).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np
import pinocchio as pin
from PIL import Image
from render_robots import add_frame_marker, caption, home_qpos

from controller.model.kinematics import Kinematics
from controller.model.robot import Robot

SEGMENT_RGBA = (0.95, 0.55, 0.05, 1.0)
UNITS = ("RIGHT_ARM", "LEFT_ARM", "LUMBER", "VEHICLE")


def unit_qpos(robot: Robot, unit: str, values: Sequence[float]) -> dict[str, float]:
    """MJCF joint name → SI value for one unit's API-unit positions."""
    names = robot.unit_joints(unit)
    out = {}
    for k, (name, v) in enumerate(zip(names, values, strict=False)):
        if unit == "VEHICLE":
            out[name] = math.radians(v) if k == 2 else v / 1e3
        elif robot.joints[name].kind == "revolute":
            out[name] = math.radians(v)
        else:
            out[name] = v / 1e3
    return out


class FrameRenderer:
    """One offscreen MuJoCo renderer with a fixed camera framing the robot at start."""

    def __init__(self, robot: Robot, width: int = 640, height: int = 480):
        self.robot = robot
        self.model = mujoco.MjModel.from_xml_path(str(robot.mjcf_path))
        self.data = mujoco.MjData(self.model)
        self.kin = Kinematics(robot)
        self.base = home_qpos(robot, self.model, self.kin)
        self.data.qpos[:] = self.base
        mujoco.mj_forward(self.model, self.data)
        points = self.data.xpos[1:]
        lo, hi = points.min(axis=0), points.max(axis=0)
        self.camera = mujoco.MjvCamera()
        self.camera.lookat[:] = (lo + hi) / 2 + np.array([0.1, 0.0, 0.2])
        self.camera.distance = 0.95 * float(np.linalg.norm(hi - lo)) + 0.8
        self.camera.azimuth, self.camera.elevation = 145.0, -18.0
        self.renderer = mujoco.Renderer(self.model, height=height, width=width)

    def render(
        self,
        units: Mapping[str, Sequence[float]],
        points: Sequence[np.ndarray],
        segments: Sequence[tuple[np.ndarray, np.ndarray]] = (),
        text: str = "",
    ) -> Image.Image:
        """``units``: unit name → API-unit positions; ``points``: control-point poses (4x4,
        original frame, m); ``segments``: (a, b) points in the original frame [m]."""
        qpos = self.base.copy()
        for unit, values in units.items():
            for name, value in unit_qpos(self.robot, unit, values).items():
                qpos[self.model.joint(name).qposadr[0]] = value
        self.data.qpos[:] = qpos
        mujoco.mj_forward(self.model, self.data)
        self.renderer.update_scene(self.data, camera=self.camera)
        scene = self.renderer.scene
        world = self.kin.original_frame
        for pose in points:
            add_frame_marker(scene, world * pin.SE3(pose), 0.1, ball=True)
        for a, b in segments:
            if scene.ngeom >= scene.maxgeom:
                break
            geom = scene.geoms[scene.ngeom]
            mujoco.mjv_initGeom(
                geom,
                mujoco.mjtGeom.mjGEOM_CAPSULE,
                np.zeros(3),
                np.zeros(3),
                np.zeros(9),
                np.array(SEGMENT_RGBA, np.float32),
            )
            wa, wb = world.act(np.asarray(a)), world.act(np.asarray(b))
            mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, 0.004, wa, wb)
            scene.ngeom += 1
        image = Image.fromarray(self.renderer.render())
        return caption(image, text) if text else image

    def close(self) -> None:
        self.renderer.close()


def contact_sheet(images: Sequence[Image.Image], cols: int = 4) -> Image.Image:
    """Thumbnails (half size) on a grid."""
    thumbs = [im.resize((im.width // 2, im.height // 2)) for im in images]
    if not thumbs:
        return Image.new("RGB", (1, 1), "white")
    rows = -(-len(thumbs) // cols)
    w, h = thumbs[0].width, thumbs[0].height
    out = Image.new("RGB", (cols * w, rows * h), "white")
    for k, t in enumerate(thumbs):
        out.paste(t, ((k % cols) * w, (k // cols) * h))
    return out
