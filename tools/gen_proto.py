#!/usr/bin/env python3
"""Regenerate the Python gRPC modules of controller/rpc/imotion.proto.

Usage: python tools/gen_proto.py [--check]

Writes controller/rpc/imotion_pb2.py, imotion_pb2.pyi and imotion_pb2_grpc.py with
``grpc_tools.protoc`` (the ``grpcio-tools`` dev dependency). protoc runs with the repository
root as its only proto path and the .proto addressed as ``controller/rpc/imotion.proto``, so
the generated gRPC module imports ``from controller.rpc import imotion_pb2`` with no
post-processing. The output depends only on the .proto and the grpcio-tools version.

With --check nothing is written; the exit status is 1 when a committed generated file is
missing or differs from fresh output (e.g. the .proto was edited without regenerating).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PROTO = Path("controller/rpc/imotion.proto")  # relative to REPO, which is the proto path
RPC_DIR = REPO / PROTO.parent
GENERATED = ("imotion_pb2.py", "imotion_pb2.pyi", "imotion_pb2_grpc.py")


def generate(out_dir: Path) -> dict[str, bytes]:
    """Run protoc into ``out_dir``; return each generated file's name and content."""
    from grpc_tools import protoc  # dev dependency; imported here so --help works without it

    args = [
        "grpc_tools.protoc",
        f"--proto_path={REPO}",
        f"--python_out={out_dir}",
        f"--pyi_out={out_dir}",
        f"--grpc_python_out={out_dir}",
        str(REPO / PROTO),
    ]
    status = protoc.main(args)
    if status != 0:
        raise RuntimeError(f"protoc failed with status {status} on {PROTO}")
    produced = out_dir / PROTO.parent
    return {name: (produced / name).read_bytes() for name in GENERATED}


def fresh_output() -> dict[str, bytes]:
    """What the generated files should contain, generated in a temporary directory."""
    with tempfile.TemporaryDirectory(prefix="imotion-proto-") as tmp:
        return generate(Path(tmp))


def stale_files() -> list[str]:
    """Names of generated files (in controller/rpc/) that are missing or out of date."""
    return [
        name
        for name, content in fresh_output().items()
        if not (RPC_DIR / name).is_file() or (RPC_DIR / name).read_bytes() != content
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 if a generated file is stale"
    )
    args = parser.parse_args(argv)
    if args.check:
        stale = stale_files()
        for name in stale:
            print(f"stale: {RPC_DIR.relative_to(REPO) / name}", file=sys.stderr)
        if stale:
            print("run: python tools/gen_proto.py", file=sys.stderr)
            return 1
        print(f"up to date: {', '.join(GENERATED)}")
        return 0
    for name, content in fresh_output().items():
        path = RPC_DIR / name
        if not path.is_file() or path.read_bytes() != content:
            path.write_bytes(content)
            print(f"wrote {path.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
