"""Pieces of the shipped configs as offline_slam --set overrides (used by run_experiments and
run_dpf to give a baseline the motion noise of the filter it is compared with)."""

from pathlib import Path

import yaml

CONFIG_DIR = Path(__file__).resolve().parent.parent / "config"


def _load(config_name):
    path = CONFIG_DIR / (config_name + ".yaml")
    return (yaml.safe_load(path.read_text()) or {}) if path.exists() else {}


def motion_overrides(config_name):
    """--set overrides giving config/`config_name`.yaml's motion block (empty when the file is
    missing or has none)."""
    motion = _load(config_name).get("motion") or {}
    return ["motion.%s=%s" % (key, value) for key, value in motion.items()]


def key_overrides(config_name, keys):
    """--set overrides giving config/`config_name`.yaml's top-level `keys` (those it has)."""
    config = _load(config_name)
    return ["%s=%s" % (key, config[key]) for key in keys if key in config]
