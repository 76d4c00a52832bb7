"""Rendering of results: one JSON object (``--json``) or readable lines, and exit codes.

Exit codes: 0 OK; 1 the daemon answered with a gRPC error; 2 bad usage or argument, daemon
unreachable, token refused; 3 ``--wait`` timed out; 4 ``--wait``: the motion ended in an
alarm; 11..16 the operation's ReturnID was NG, STATUS_ERR, VALUE_ERR, NOT_SV_ON_ERR,
FULL_MOTION_QUEUE_ERR, CANNOT_REACH_TARGET_ERR (10 + |id|); 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import enum
import json
import math
from typing import Any

import numpy as np

from controller.client import codes
from controller.client.poses import rpy_of, xyz_of
from controller.client.service import Result
from controller.client.types import Alarm, CarPosWithElbow

EXIT_OK = 0
EXIT_RPC_ERROR = 1
EXIT_USAGE = 2
EXIT_WAIT_TIMEOUT = 3
EXIT_ALARM = 4
EXIT_INTERRUPTED = 130


def exit_code(return_id: int) -> int:
    """The exit status for a ReturnID code (0 for OK, 10 + |id| for the known errors)."""
    if return_id == codes.OK:
        return EXIT_OK
    if return_id in codes.RETURN_CODE_NAMES:
        return 10 + abs(return_id)
    return EXIT_RPC_ERROR


def jsonable(value: Any) -> Any:
    """Python results as JSON values: arrays -> nested lists, structs -> objects, enums -> names.

    Non-finite floats become null (JSON has no NaN).
    """
    if isinstance(value, enum.Enum):
        return value.name
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, tuple) and hasattr(value, "_asdict"):
        return {k: jsonable(v) for k, v in value._asdict().items()}
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def result_json(result: Result, operation: str, extra: dict[str, Any] | None = None) -> str:
    """One JSON object: operation, id, name, comment, outputs (+ extra keys)."""
    rid = result.return_id
    data: dict[str, Any] = {
        "operation": operation,
        "id": rid.id,
        "name": rid.name,
        "comment": rid.comment,
        "outputs": jsonable(result.outputs),
    }
    if extra:
        data.update(jsonable(extra))
    return json.dumps(data)


def fmt_number(x: float) -> str:
    if not math.isfinite(x):
        return str(x)
    text = f"{x:.3f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def fmt_numbers(values: Any) -> str:
    return " ".join(fmt_number(float(v)) for v in values)


def fmt_pose(hg: np.ndarray) -> str:
    """``xyz [mm] ... rpy [deg] ...`` of an HgMatrix (raw numbers if it is not 3 x 4)."""
    if getattr(hg, "shape", None) != (3, 4):
        return f"(malformed HgMatrix: {fmt_numbers(np.ravel(hg))})"
    return f"xyz {fmt_numbers(xyz_of(hg))} mm, rpy {fmt_numbers(rpy_of(hg))} deg"


def fmt_value(name: str, value: Any, operation: str = "") -> str:
    """One output as text."""
    if isinstance(value, np.ndarray):
        return fmt_pose(value)
    if isinstance(value, enum.Enum):
        return value.name
    if isinstance(value, tuple) and hasattr(value, "_asdict"):
        if isinstance(value, CarPosWithElbow):
            return (
                f"{fmt_pose(value.carPos)}, elbow {fmt_number(value.elbow)} deg, "
                f"structFlag {value.structFlag}"
            )
        if isinstance(value, Alarm):
            module = f" [{value.moduleName}]" if value.moduleName else ""
            return f"0x{value.code:04X} {value.type.name}{module}: {value.description}"
        return ", ".join(f"{k} {fmt_value(k, v)}" for k, v in value._asdict().items())
    if isinstance(value, list):
        if value and all(isinstance(v, float) for v in value):
            return fmt_numbers(value)
        if not value:
            return "(none)"
        return "\n  " + "\n  ".join(fmt_value(name, v) for v in value)
    if isinstance(value, float):
        return fmt_number(value)
    if name == "statusId" and isinstance(value, int):
        return f"0x{value:03X} ({codes.state_name(value)})"
    if name == "state" and operation.endswith("getState") and isinstance(value, int):
        states = ", ".join(codes.jara_state_names(value)) or "servo off, idle"
        return f"0x{value:02X} ({states})"
    return str(value)


def result_text(result: Result, operation: str) -> str:
    """``OK (0): comment`` and one ``name: value`` line per output."""
    lines = [str(result.return_id)]
    for name, value in result.outputs.items():
        lines.append(f"{name}: {fmt_value(name, value, operation)}")
    return "\n".join(lines)
