"""Shared fixtures of the estimator tests: small return matrices with known structure."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def continuous_returns() -> np.ndarray:
    """(12, 8) returns: a per-policy mean plus Gaussian noise, as dense rewards give."""
    rng = np.random.default_rng(20240611)
    return rng.normal(-20.0, 5.0, size=(12, 1)) + rng.normal(0.0, 2.0, size=(12, 8))


@pytest.fixture
def integer_returns() -> np.ndarray:
    """(15, 10) returns in {-50, …, 0} with many ties, as sparse rewards give."""
    rng = np.random.default_rng(7)
    success = rng.uniform(0.0, 0.6, size=(15, 1))
    return -np.round(50 * (1 - success) * rng.uniform(0.7, 1.0, size=(15, 10)))
