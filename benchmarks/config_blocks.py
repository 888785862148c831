"""Pieces of the shipped configs as offline_slam --set overrides (used by run_experiments and
run_dpf to give a baseline the motion noise, and the landmark existence settings, of the filter
it is compared with)."""

from pathlib import Path

import yaml

CONFIG_DIR = Path(__file__).resolve().parent.parent / "config"


def _load(config_name):
    path = CONFIG_DIR / (config_name + ".yaml")
    return (yaml.safe_load(path.read_text()) or {}) if path.exists() else {}


def block_overrides(config_name, block):
    """--set overrides giving config/`config_name`.yaml's `block` section (empty when the file is
    missing or has none)."""
    section = _load(config_name).get(block) or {}
    return ["%s.%s=%s" % (block, key, value) for key, value in section.items()]


def motion_overrides(config_name):
    """block_overrides(config_name, "motion")."""
    return block_overrides(config_name, "motion")


def key_overrides(config_name, keys):
    """--set overrides giving config/`config_name`.yaml's top-level `keys` (those it has)."""
    config = _load(config_name)
    return ["%s=%s" % (key, config[key]) for key in keys if key in config]
