"""Pieces of the shipped configs as offline_slam --set overrides (used by run_experiments and
run_dpf to give a baseline the motion noise of the filter it is compared with)."""

from pathlib import Path

import yaml

CONFIG_DIR = Path(__file__).resolve().parent.parent / "config"


def motion_overrides(config_name):
    """--set overrides giving config/`config_name`.yaml's motion block (empty when the file is
    missing or has none)."""
    path = CONFIG_DIR / (config_name + ".yaml")
    if not path.exists():
        return []
    motion = (yaml.safe_load(path.read_text()) or {}).get("motion") or {}
    return ["motion.%s=%s" % (key, value) for key, value in motion.items()]
