"""Shipped configuration data: robot profiles, models and the systemd unit."""

from pathlib import Path

CONFIG_DIR = Path(__file__).resolve().parent
ROBOTS_DIR = CONFIG_DIR / "robots"


def robot_ids() -> list[str]:
    """Ids of the robots shipped under ``config/robots/`` (sorted)."""
    return sorted(p.name for p in ROBOTS_DIR.iterdir() if (p / "profile.yaml").is_file())
