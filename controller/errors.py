"""imotion's exceptions: one base, each subclass carrying the return code it ends a call with.

A service call that raises one of these answers with ``error.code`` and ``error.comment``
(never a crash); the command channel carries the same pair across processes.
"""

from __future__ import annotations

from controller.vocabulary import ReturnCode


class ImotionError(Exception):
    """Base of imotion's errors; ``code`` is the return code a call ends with."""

    code: ReturnCode = ReturnCode.NG

    def __init__(self, comment: str):
        super().__init__(comment)
        self.comment = comment

    def __reduce__(self) -> tuple[object, ...]:
        """Pickled with its attributes (code, comment) whatever the subclass's ``__init__``
        takes: a planning worker process raises it, the gateway re-raises the same error."""
        return (_restore, (type(self), self.args, dict(self.__dict__)))


def _restore(cls: type[ImotionError], args: tuple[object, ...], state: dict) -> ImotionError:
    error = cls.__new__(cls)
    error.args = args
    error.__dict__.update(state)
    return error


class Refused(ImotionError):
    """A call refused with an explicit code (state, queue, reachability...)."""

    def __init__(self, code: ReturnCode | int, comment: str):
        super().__init__(comment)
        self.code = ReturnCode(code)


class ArgumentError(ImotionError, ValueError):
    """A value given at the API edge is invalid; the comment names which and why."""

    code = ReturnCode.VALUE_ERR


class StateError(ImotionError):
    """The robot's state does not allow the call."""

    code = ReturnCode.STATUS_ERR


class UnreachableError(ImotionError):
    """A target (or a path to it) is out of the robot's reach."""

    code = ReturnCode.CANNOT_REACH_TARGET_ERR


class ChannelError(ImotionError, RuntimeError):
    """The control process cannot be reached."""


class ConfigError(ImotionError, ValueError):
    """A configuration or robot description file is invalid; one line per problem."""
