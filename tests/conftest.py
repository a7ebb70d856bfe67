"""Shared fixtures: compose the real Hydra config (shrunk where needed) into a temporary directory."""

from __future__ import annotations

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from omegaconf import open_dict

from taskcomplexity.cli import CONF_DIR


@pytest.fixture
def compose_config(tmp_path):
    """``compose_config(*overrides)`` → the composed config with ``paths.outputs`` in ``tmp_path``."""

    def _compose(*overrides: str):
        GlobalHydra.instance().clear()
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            cfg = compose("config", overrides=list(overrides))
        with open_dict(cfg):
            if not any(o.startswith("paths.outputs=") for o in overrides):
                cfg.paths.outputs = str(tmp_path / "outputs")
        return cfg

    yield _compose
    GlobalHydra.instance().clear()


def pytest_report_header(config):
    """The kernels this run computes with (numba's target, NumPy's dispatch, torch's capability, the BLAS)."""
    from cpu_paths import describe

    return f"CPU code paths: {describe()}"
