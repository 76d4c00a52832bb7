#!/usr/bin/env python3
"""Regenerate the omniORBpy stubs of the product's IDL (controller/corba/idl/*.idl).

Usage: python tools/gen_idl.py [--check]

Runs ``omniidl -bpython -Wbpackage=controller.corba.stubs`` (the ``corba`` extra:
jeteve-omniorb) in the IDL directory on every ``*.idl`` file, into a temporary directory, and
copies the tree under ``controller/corba/stubs/``. The output depends only on the IDL and the
omniidl version.

With --check nothing is written; the exit status is 1 when a committed stub is missing,
differs from fresh output, or is left over from an IDL file that no longer exists.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
IDL_DIR = REPO / "controller" / "corba" / "idl"
PACKAGE = "controller.corba.stubs"
STUBS = REPO / Path(*PACKAGE.split("."))


def omniidl() -> str:
    """The omniidl of this interpreter's environment (else the one on PATH)."""
    here = Path(sysconfig.get_path("scripts")) / "omniidl"
    found = str(here) if here.is_file() else shutil.which("omniidl")
    if found is None:
        raise RuntimeError("omniidl not found: pip install 'imotion[corba]'")
    return found


def fresh_output() -> dict[str, bytes]:
    """Every generated file (path relative to the stubs package) and its content."""
    idl = sorted(p.name for p in IDL_DIR.glob("*.idl"))
    with tempfile.TemporaryDirectory(prefix="imotion-idl-") as tmp:
        cmd = [omniidl(), "-bpython", f"-Wbpackage={PACKAGE}", "-C", tmp, *idl]
        done = subprocess.run(cmd, cwd=IDL_DIR, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise RuntimeError(f"omniidl failed ({done.returncode}): {done.stderr.strip()}")
        root = Path(tmp) / Path(*PACKAGE.split("."))
        return {
            str(p.relative_to(root)): p.read_bytes()
            for p in sorted(root.rglob("*.py"))
            if "__pycache__" not in p.parts
        }


def committed() -> dict[str, bytes]:
    return {
        str(p.relative_to(STUBS)): p.read_bytes()
        for p in sorted(STUBS.rglob("*.py"))
        if "__pycache__" not in p.parts
    }


def stale_files() -> list[str]:
    """Stub files (relative to controller/corba/stubs) missing, out of date or left over."""
    fresh, have = fresh_output(), committed()
    return sorted(name for name in fresh.keys() | have.keys() if fresh.get(name) != have.get(name))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 if a stub is stale"
    )
    args = parser.parse_args(argv)
    if args.check:
        stale = stale_files()
        for name in stale:
            print(f"stale: {(STUBS / name).relative_to(REPO)}", file=sys.stderr)
        if stale:
            print("run: python tools/gen_idl.py", file=sys.stderr)
            return 1
        print(f"up to date: {len(committed())} files under {STUBS.relative_to(REPO)}")
        return 0
    fresh = fresh_output()
    for name in set(committed()) - set(fresh):
        (STUBS / name).unlink()
        print(f"removed {(STUBS / name).relative_to(REPO)}")
    for name, content in fresh.items():
        path = STUBS / name
        if not path.is_file() or path.read_bytes() != content:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(content)
            print(f"wrote {path.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
