"""The ``--version`` of every imotion tool (imotiond, imotion, imotion-sim, imotion-can).

The version is the installed distribution's (``pyproject.toml``); a source tree that is not
installed answers ``unknown``. Tools add the flag with :func:`add_version_argument`.
"""

from __future__ import annotations

import argparse
from importlib import metadata

DISTRIBUTION = "imotion"


def version() -> str:
    """The installed ``imotion`` version, e.g. ``0.1.0`` (``unknown`` when not installed)."""
    try:
        return metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        return "unknown"


def version_line(prog: str) -> str:
    """``<prog> <version>``, the line ``--version`` prints."""
    return f"{prog} {version()}"


def add_version_argument(parser: argparse.ArgumentParser) -> None:
    """``--version``: print ``<prog> <version>`` on stdout and exit 0."""
    parser.add_argument(
        "--version", action="version", version=version_line(parser.prog), help="print the version"
    )
