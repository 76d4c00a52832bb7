#!/usr/bin/env python3
"""A plain omniORBpy client of imotion's Spec A interface (IntegratedMotionInterface).

Usage: python tools/corba_example.py --naming corbaloc::127.0.0.1:2809/NameService
       python tools/corba_example.py --ior /run/imotion/ior/spec_a.ior

Finds the servant (in the naming service under ``imotion/IntegratedMotionInterface``, or
from an IOR file written with ``corba.ior_dir``), prints the state and the right control
point, switches the servos on, moves the right hand 20 mm up in a straight line (BASE_FRAME,
mm and deg), waits until it stops and prints the pose again. Needs only omniORBpy and stubs
generated from the product's IDL (here ``controller.corba.stubs``; any client can generate
its own with ``omniidl -bpython controller/corba/idl/IntegratedMotionInterface.idl``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import CosNaming
from omniORB import CORBA

from controller.corba.stubs import _GlobalIDL as IM


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--naming", help="naming service, e.g. corbaloc::127.0.0.1:2809/NameService")
    where.add_argument("--ior", type=Path, help="IOR file of the servant (corba.ior_dir)")
    parser.add_argument("--name", default="imotion/IntegratedMotionInterface")
    args = parser.parse_args()

    orb = CORBA.ORB_init(["corba_example", "-ORBendPoint", "giop:tcp:127.0.0.1:0"], CORBA.ORB_ID)
    if args.naming:
        root = orb.string_to_object(args.naming)._narrow(CosNaming.NamingContextExt)
        obj = root.resolve_str(args.name)
    else:
        obj = orb.string_to_object(args.ior.read_text().strip())
    robot = obj._narrow(IM.IntegratedMotionInterface)

    rid, status, message = robot.getState()
    print(f"getState: 0x{status:03x} {message} ({rid.comment})")
    rid = robot.servoOn()
    print(f"servoOn: {rid.id} {rid.comment}")
    up = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 20.0]]  # [R | p], mm
    rid = robot.moveLinearCartesianRel(
        IM.RIGHT, IM.BASE_FRAME, up, IM.CartesianSpeed(50.0, 30.0),
        IM.CartesianAccel(200.0, 60.0), False,
    )  # fmt: skip
    print(f"moveLinearCartesianRel: {rid.id} {rid.comment}")
    end = time.monotonic() + 30.0
    while robot.isMoving() and time.monotonic() < end:  # isMoving: a bare boolean
        time.sleep(0.05)
    rid, pos = robot.getFeedbackPosCartesian(IM.RIGHT, IM.ORIGINAL_FRAME)
    x, y, z = (row[3] for row in pos.carPos)
    print(f"right control point: x {x:.1f} y {y:.1f} z {z:.1f} mm, elbow {pos.elbow:.1f} deg")
    orb.destroy()
    return 0 if rid.id == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
