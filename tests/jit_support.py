"""numba's kernels compiled before the first test, in worker processes beside the collection.

A fresh clone has no numba cache: each kernel compiles where it is first used, a few seconds
of CPU each (~60 s in all), one after the other in the test process or, worse, in a daemon
that a test starts and waits for (twice where two processes start at once, a CAN master and
its emulator). Those compiled at import compile in this process during the collection;
``tests/conftest.py`` starts two workers (:data:`GROUPS`) at configuration, beside the
collection, for those compiled when a controller or an emulator is built, and its session
fixture waits for them before the first test. Each fills numba's on-disk cache (beside the
sources, or in ``NUMBA_CACHE_DIR``), which every process of the suite then loads. With a
warm cache they would only load it: once they have filled a cache (:func:`stamp`), no
session starts them again for it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The workers, one per group of kernels that a controller or an emulator compiles when it
#: is built (the collection compiles, in this process, those compiled at import).
GROUPS = ("collision", "emulator")


def compile_collision() -> None:
    """The kinematics' and collision kernels (distances, the QP's rows: ~25 s of CPU), as a
    controller builds them."""
    from controller.model.collision_pairs import robot_distances
    from controller.model.kinematics import Kinematics
    from controller.model.robot import load_robot
    from controller.qp.constraints.collision import CollisionAvoidance

    kin = Kinematics(load_robot("pa10"))
    distances = robot_distances(kin)
    CollisionAvoidance(kin, distances, kin.robot.profile.collision_avoidance, 0.002)


def compile_emulator() -> None:
    """The drive emulator's kernels (SYNC round, inbox, plant), as it builds them."""
    from controller.model.robot import load_robot
    from hal.emulator.emulator import DriveEmulator

    DriveEmulator(load_robot("smartpal5"), period=0.002).close()


def stamp() -> Path:
    """A file saying that the workers filled the cache for these kernel sources, this numba
    and this Python: the next sessions start none (the kernels load where used)."""
    import numba

    from controller.model import jit

    cache = os.environ.get("NUMBA_CACHE_DIR") or ROOT / "controller" / "model" / "__pycache__"
    version = f"numba{numba.__version__}-py{sys.version_info[0]}{sys.version_info[1]}"
    return Path(cache) / f"imotion-tests-{jit.KERNEL_SOURCES.hex()[:16]}-{version}.warm"


def start() -> list[subprocess.Popen[bytes]]:
    """The workers, started (none where the kernels are not compiled, or where they
    already filled this cache)."""
    from controller.model import jit

    if not jit.available() or stamp().exists():
        return []
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return [
        subprocess.Popen(
            [sys.executable, "-m", "tests.jit_support", group],
            cwd=ROOT,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        for group in GROUPS
    ]


def wait(workers: list[subprocess.Popen[bytes]], timeout: float = 600.0) -> None:
    """Wait for the workers; a failed one is a warning (its kernels then compile where they
    are first used, as without it)."""
    for worker in workers:
        try:
            _, err = worker.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            worker.kill()
            _, err = worker.communicate()
        if worker.returncode != 0:
            tail = err.decode(errors="replace")[-2000:]
            warnings.warn(f"{' '.join(map(str, worker.args))} failed:\n{tail}", stacklevel=2)
    if workers and all(worker.returncode == 0 for worker in workers):
        path = stamp()
        path.parent.mkdir(parents=True, exist_ok=True)
        path.touch()


if __name__ == "__main__":
    {"collision": compile_collision, "emulator": compile_emulator}[sys.argv[1]]()
