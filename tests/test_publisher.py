"""The snapshot publisher: what the control process shows the gateway each cycle."""

from __future__ import annotations

from pathlib import Path

from controller.contract import snapshot as snap
from controller.control.loop import FixedRateLoop
from controller.control.publisher import SnapshotPublisher
from controller.model.alarms import AlarmCode
from tests.motion_support import make_core


def test_alarms_reach_the_snapshot_when_they_change_and_only_then(tmp_path: Path):
    core = make_core("pa10")
    loop = FixedRateLoop(500.0, lambda cycle, t: True, realtime=False)
    publisher = SnapshotPublisher(tmp_path / "snapshot", core, core.hw, loop, 500.0, 1)
    reader = snap.SnapshotReader(publisher.writer.path, len(core.hw.joint_names))
    writes: list[list[dict]] = []
    set_alarms = publisher.writer.set_alarms

    def counted(alarms: list[dict]) -> None:
        writes.append(alarms)
        set_alarms(alarms)

    publisher.writer.set_alarms = counted  # type: ignore[method-assign]

    def published() -> list[tuple[int, str]]:
        publisher.publish(0, False, 0, 0)
        return [(a["code"], a["module"]) for a in reader.read().alarms]

    assert published() == [] and published() == []
    core.warn(AlarmCode.MOTION_INCOMPLETE, "motion", "first")
    assert published() == [(int(AlarmCode.MOTION_INCOMPLETE), "motion")]
    core.raise_alarm(AlarmCode.QP_FAILURE, "qp", "second")
    assert published() == [
        (int(AlarmCode.MOTION_INCOMPLETE), "motion"),
        (int(AlarmCode.QP_FAILURE), "qp"),
    ]
    assert published() == [
        (int(AlarmCode.MOTION_INCOMPLETE), "motion"),
        (int(AlarmCode.QP_FAILURE), "qp"),
    ]
    core.clear_alarms()
    assert published() == [] and published() == []
    # Rewritten on the first publish and on each of the three changes, not every cycle.
    assert len(writes) == 4
    publisher.close()
