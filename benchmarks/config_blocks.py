"""Pieces of the shipped configs as offline_slam --set overrides (used by run_experiments and
run_dpf to give a baseline the motion noise, landmark existence and particle count of the filter
it is compared with)."""

import sys
from pathlib import Path

import yaml

CONFIG_DIR = Path(__file__).resolve().parent.parent / "config"


def _load(config_name):
    path = CONFIG_DIR / (config_name + ".yaml")
    return (yaml.safe_load(path.read_text()) or {}) if path.exists() else {}


def _value(value):
    """A YAML scalar as offline_slam --set takes it (booleans as true / false)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None or isinstance(value, (list, dict)):
        raise ValueError("config_blocks: cannot pass %r as a --set value" % (value,))
    return str(value)


def pinned_overrides(config_name, blocks=(), keys=()):
    """--set overrides giving config/`config_name`.yaml's sections `blocks` (each must be there:
    a pin that pins nothing is an error) and its top-level `keys` (those it has)."""
    config = _load(config_name)
    overrides = []
    for block in blocks:
        section = config.get(block) or {}
        if not section:
            sys.exit("config_blocks: config/%s.yaml has no '%s' block to pin onto the baseline"
                     % (config_name, block))
        overrides += ["%s.%s=%s" % (block, key, _value(value)) for key, value in section.items()]
    return overrides + ["%s=%s" % (key, _value(config[key])) for key in keys if key in config]
