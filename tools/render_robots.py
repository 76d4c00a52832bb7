#!/usr/bin/env python3
"""Render each robot in MuJoCo (offscreen) at its home pose with its control points marked.

Usage: python tools/render_robots.py [--out DIR] [--size W H] [ROBOT_ID ...]
Writes DIR/<id>.png per robot and DIR/robots.png (all of them on one sheet).
Markers: control point = sphere with its frame's axes (x red, y green, z blue); original
frame = the same axes, smaller, without sphere. Control-point poses come from
controller.model.kinematics (Pinocchio), so the picture also shows that the two models agree.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import mujoco
import numpy as np
import pinocchio as pin
from PIL import Image, ImageDraw

from config import robot_ids
from controller.model.kinematics import Kinematics
from controller.model.robot import Robot, load_robot
from controller.model.yaml_source import ConfigError

AXIS_RGBA = ((0.9, 0.1, 0.1, 1.0), (0.1, 0.75, 0.1, 1.0), (0.1, 0.2, 0.95, 1.0))


def home_qpos(robot: Robot, model: mujoco.MjModel, kin: Kinematics) -> np.ndarray:
    """MuJoCo qpos for the home pose, grippers half open."""
    qpos = np.zeros(model.nq)
    q = kin.home()
    for name in kin.joint_names:
        qpos[model.joint(name).qposadr[0]] = q[kin.index(name)]
    for g in robot.profile.grippers.values():
        for name, opened, closed in zip(g.joints, g.open, g.closed, strict=True):
            qpos[model.joint(name).qposadr[0]] = robot.joints[name].to_si((opened + closed) / 2)
    return qpos


def add_frame_marker(scene: mujoco.MjvScene, pose: pin.SE3, length: float, ball: bool) -> None:
    """Append axis arrows (and a ball) for ``pose`` to the scene's extra geoms."""
    items: list[tuple[int, float, np.ndarray, np.ndarray, tuple[float, ...]]] = []
    p = pose.translation
    for i in range(3):
        end = p + length * pose.rotation[:, i]
        items.append((mujoco.mjtGeom.mjGEOM_ARROW, 0.006, p, end, AXIS_RGBA[i]))
    for gtype, width, a, b, rgba in items:
        if scene.ngeom >= scene.maxgeom:
            return
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(
            geom, gtype, np.zeros(3), np.zeros(3), np.zeros(9), np.array(rgba, np.float32)
        )
        mujoco.mjv_connector(geom, gtype, width, a, b)
        scene.ngeom += 1
    if ball and scene.ngeom < scene.maxgeom:
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(
            geom,
            mujoco.mjtGeom.mjGEOM_SPHERE,
            np.array([0.022, 0, 0]),
            p,
            np.eye(3).ravel(),
            np.array((1.0, 0.85, 0.1, 1.0), np.float32),
        )
        scene.ngeom += 1


def render(robot: Robot, width: int, height: int) -> Image.Image:
    model = mujoco.MjModel.from_xml_path(str(robot.mjcf_path))
    data = mujoco.MjData(model)
    kin = Kinematics(robot)
    data.qpos[:] = home_qpos(robot, model, kin)
    mujoco.mj_forward(model, data)
    kin.update(kin.home())

    points = data.xpos[1:]
    lo, hi = points.min(axis=0), points.max(axis=0)
    cam = mujoco.MjvCamera()
    cam.lookat[:] = (lo + hi) / 2
    cam.distance = 1.25 * float(np.linalg.norm(hi - lo)) + 0.8
    cam.azimuth, cam.elevation = 145.0, -18.0

    renderer = mujoco.Renderer(model, height=height, width=width)
    renderer.update_scene(data, camera=cam)
    add_frame_marker(renderer.scene, kin.original_frame, 0.12, ball=False)
    for side in kin.arms:
        add_frame_marker(renderer.scene, kin.original_frame * kin.pose(side), 0.1, ball=True)
    image = Image.fromarray(renderer.render())
    renderer.close()
    return image


def caption(image: Image.Image, text: str) -> Image.Image:
    draw = ImageDraw.Draw(image)
    draw.rectangle((0, 0, image.width, 26), fill=(255, 255, 255))
    draw.text((10, 7), text, fill=(20, 20, 20))
    return image


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("robots", nargs="*", help="robot ids (default: all shipped)")
    parser.add_argument("--out", type=Path, default=Path("out/robots"))
    parser.add_argument("--size", type=int, nargs=2, default=(640, 640), metavar=("W", "H"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    tiles = []
    for rid in args.robots or robot_ids():
        robot = load_robot(rid)
        try:
            image = render(robot, *args.size)
        except mujoco.FatalError as exc:  # no GL context: say how to get one
            print(f"cannot render with MUJOCO_GL={os.environ['MUJOCO_GL']}: {exc}", file=sys.stderr)
            print("try MUJOCO_GL=egl or MUJOCO_GL=osmesa (needs libosmesa6)", file=sys.stderr)
            return 1
        path = args.out / f"{rid}.png"
        image.save(path)
        print(f"wrote {path}")
        tiles.append(caption(image.copy(), f"{robot.profile.name}  ({rid}): home pose"))
    cols = 2 if len(tiles) > 1 else 1
    rows = -(-len(tiles) // cols)
    w, h = tiles[0].width, tiles[0].height
    sheet = Image.new("RGB", (cols * w, rows * h), "white")
    for i, t in enumerate(tiles):
        sheet.paste(t, ((i % cols) * w, (i // cols) * h))
    sheet.save(args.out / "robots.png")
    print(f"wrote {args.out / 'robots.png'}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except ConfigError as exc:  # a broken or unknown robot: say which and why
        print(exc, file=sys.stderr)
        sys.exit(2)
