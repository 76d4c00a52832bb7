"""Python methods generated from the imotion.v1 service descriptors.

Every RPC becomes a method named after the original operation (the RPC name with its first
letter lowered: ``GetState`` -> ``getState``, ``ServoONArm`` -> ``servoONArm``). Its parameters
are the request fields in order, named as in the original (``absHgMat``, ``isHoldOtherArm``),
minus fields bound by the proxy (the JARA_ARM ``arm``). It returns a :class:`Result`: the tuple
``(ReturnID, out1, ...)`` of the response, outputs in field order and in Python form.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

from google.protobuf.descriptor import FieldDescriptor, MethodDescriptor
from google.protobuf.message import Message

from controller.client.codes import ReturnID
from controller.client.convert import from_field, message_class, to_field
from controller.rpc import imotion_pb2, imotion_pb2_grpc

RETURN_ID = "return_id"


class Invoker(Protocol):
    """What a proxy needs from the connection: the channel and a guarded unary call."""

    channel: Any

    def unary(self, label: str, rpc: Callable[..., Any], request: Message) -> Any: ...


def operation_name(rpc: str) -> str:
    """The original lowerCamel operation name of an RPC (``MoveCPHoldAbs`` -> ``moveCPHoldAbs``)."""
    return rpc[0].lower() + rpc[1:]


class Result(tuple[Any, ...]):
    """``(ReturnID, out1, ...)``; also ``.return_id``, ``.ok``, ``.outputs`` and outputs by name."""

    return_id: ReturnID
    outputs: dict[str, Any]

    def __new__(cls, return_id: ReturnID, outputs: Mapping[str, Any]) -> Result:
        self = super().__new__(cls, (return_id, *outputs.values()))
        self.return_id = return_id
        self.outputs = dict(outputs)
        return self

    @property
    def ok(self) -> bool:
        return self.return_id.ok

    def __getattr__(self, name: str) -> Any:
        outputs = self.__dict__.get("outputs", {})
        if name in outputs:
            return outputs[name]
        raise AttributeError(f"result has no output {name!r} (outputs: {', '.join(outputs)})")

    def __repr__(self) -> str:
        outs = ", ".join(f"{k}={v!r}" for k, v in self.outputs.items())
        return f"Result({self.return_id!r}{', ' if outs else ''}{outs})"


def _type_name(field: FieldDescriptor) -> str:
    if field.type == FieldDescriptor.TYPE_MESSAGE:
        base = field.message_type.name
    elif field.type == FieldDescriptor.TYPE_ENUM:
        base = field.enum_type.name
    else:
        base = {
            FieldDescriptor.TYPE_DOUBLE: "float",
            FieldDescriptor.TYPE_BOOL: "bool",
            FieldDescriptor.TYPE_STRING: "str",
        }.get(field.type, "int")
    return f"list[{base}]" if field.is_repeated else base


class Operation:
    """One RPC as a callable with the original name and argument names."""

    def __init__(
        self,
        invoker: Invoker,
        service: str,
        method: MethodDescriptor,
        rpc: Callable[..., Any],
        bound: Mapping[str, Any],
    ) -> None:
        self.service = service
        self.method = method
        self.__name__ = operation_name(method.name)
        self._invoker = invoker
        self._rpc = rpc
        self._bound = dict(bound)
        self._request = message_class(method.input_type)
        self.fields = [f for f in method.input_type.fields if f.name not in self._bound]
        self.outputs = [f for f in method.output_type.fields if f.name != RETURN_ID]
        self._by_name = {f.json_name: f for f in self.fields} | {f.name: f for f in self.fields}
        servicer = getattr(imotion_pb2_grpc, f"{service}Servicer", None)
        summary = inspect.getdoc(getattr(servicer, method.name, None)) or ""
        args = ", ".join(f"{f.json_name}: {_type_name(f)}" for f in self.fields)
        outs = ", ".join(f"{f.json_name}: {_type_name(f)}" for f in self.outputs)
        self.__doc__ = (
            f"{self.__name__}({args}) -> (ReturnID{', ' if outs else ''}{outs})\n\n{summary}"
        )
        self.__signature__ = inspect.Signature(
            [
                inspect.Parameter(f.json_name, inspect.Parameter.POSITIONAL_OR_KEYWORD)
                for f in self.fields
            ]
        )

    @property
    def label(self) -> str:
        """``Service.operation`` plus the bound fields, for messages."""
        bound = ", ".join(f"{k}={getattr(v, 'name', v)}" for k, v in self._bound.items())
        return f"{self.service}.{self.__name__}" + (f"({bound})" if bound else "")

    def bind(self, args: Sequence[Any], kwargs: Mapping[str, Any]) -> dict[str, Any]:
        """Arguments by proto field name; TypeError on a wrong count or an unknown name."""
        names = ", ".join(f.json_name for f in self.fields) or "no arguments"
        if len(args) > len(self.fields):
            raise TypeError(f"{self.__name__}() takes {names}; got {len(args)} positional")
        values = {f.name: v for f, v in zip(self.fields, args, strict=False)}
        for key, value in kwargs.items():
            field = self._by_name.get(key)
            if field is None:
                raise TypeError(
                    f"{self.__name__}() got an unknown argument {key!r} (takes {names})"
                )
            if field.name in values:
                raise TypeError(f"{self.__name__}() got two values for {field.json_name!r}")
            values[field.name] = value
        missing = [f.json_name for f in self.fields if f.name not in values]
        if missing:
            raise TypeError(f"{self.__name__}() missing {', '.join(missing)} (takes {names})")
        return values

    def request(self, *args: Any, **kwargs: Any) -> Message:
        """The request message these arguments make (nothing is sent)."""
        values = self.bind(args, kwargs) | self._bound
        by_name = self.method.input_type.fields_by_name
        fields = {
            name: to_field(by_name[name], value, f"{self.__name__}: {by_name[name].json_name}")
            for name, value in values.items()
        }
        return self._request(**fields)

    def result(self, response: Message) -> Result:
        """The Python result of a response message."""
        rid = getattr(response, RETURN_ID)
        outputs = {f.json_name: from_field(f, getattr(response, f.name)) for f in self.outputs}
        return Result(ReturnID(int(rid.id), str(rid.comment)), outputs)

    def __call__(self, *args: Any, **kwargs: Any) -> Result:
        request = self.request(*args, **kwargs)
        return self.result(self._invoker.unary(self.label, self._rpc, request))

    def __repr__(self) -> str:
        return f"<operation {self.label}{self.__signature__}>"


class ServiceProxy:
    """The operations of one or more services (merged), as attributes by original name."""

    def __init__(
        self,
        invoker: Invoker,
        services: Sequence[str],
        bound: Mapping[str, Any] | None = None,
        label: str = "",
    ) -> None:
        self.label = label or "+".join(services)
        ops: dict[str, Operation] = {}
        for service in services:
            descriptor = imotion_pb2.DESCRIPTOR.services_by_name[service]
            stub = getattr(imotion_pb2_grpc, f"{service}Stub")(invoker.channel)
            for method in descriptor.methods:
                op = Operation(invoker, service, method, getattr(stub, method.name), bound or {})
                if op.__name__ in ops:
                    raise RuntimeError(f"{self.label}: operation {op.__name__} defined twice")
                ops[op.__name__] = op
        self._operations = ops

    @property
    def operations(self) -> dict[str, Operation]:
        """Operation name -> operation, in proto order."""
        return dict(self._operations)

    def __getattr__(self, name: str) -> Operation:
        ops = self.__dict__.get("_operations", {})
        if name in ops:
            return ops[name]
        close = [n for n in ops if n.lower() == name.lower()]
        hint = f"; did you mean {close[0]}?" if close else ""
        raise AttributeError(f"{self.label} has no operation {name!r}{hint}")

    def __dir__(self) -> list[str]:
        return [*super().__dir__(), *self._operations]

    def __repr__(self) -> str:
        return f"<{self.label}: {len(self._operations)} operations>"
