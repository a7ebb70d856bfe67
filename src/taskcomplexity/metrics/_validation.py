"""Validation of the estimators' public arguments.

Every public function of :mod:`taskcomplexity.metrics` checks its arguments here, so that a bad
value fails at the boundary with a message that names the parameter, what is allowed and what was
received.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import numpy as np


def validate_returns(returns: object) -> np.ndarray:
    """Check a return matrix and return it as a C-contiguous float64 array.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Undiscounted episode returns; row n is policy n, column e is episode e.

    Returns
    -------
    numpy.ndarray, shape (N, M), float64
        The same values (a copy only when a conversion was needed).

    Raises
    ------
    TypeError
        If the values are not real numbers (strings, complex numbers, booleans, objects).
    ValueError
        If the array is not 2-D, has fewer than 2 policies or 2 episodes, or holds a NaN or an
        infinity (the message names the first offending policy and episode, in row-major order).
    """
    array = np.asarray(returns)
    if array.dtype == np.bool_ or not (
        np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)
    ):
        raise TypeError(f"returns must be an array of real numbers, got dtype {array.dtype}")
    if array.ndim != 2:
        raise ValueError(
            f"returns must be a 2-D array of shape (policies, episodes), got an array with shape {array.shape}"
        )
    n_policies, n_episodes = array.shape
    if n_policies < 2:
        raise ValueError(f"returns must have at least 2 policies (rows), got {n_policies}")
    if n_episodes < 2:
        raise ValueError(f"returns must have at least 2 episodes (columns), got {n_episodes}")
    array = np.ascontiguousarray(array, dtype=np.float64)
    finite = np.isfinite(array)
    if not finite.all():
        policy, episode = np.unravel_index(int(np.argmin(finite.ravel())), array.shape)
        raise ValueError(
            f"returns must be finite; found {array[policy, episode]} at policy {policy}, episode {episode}"
        )
    return array


def check_int(value: object, name: str, *, minimum: int) -> int:
    """Return ``value`` as an int if it is an integer (not a bool) >= ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def check_bins(bins: object) -> int:
    """Return the number of histogram bins, an integer >= 2."""
    return check_int(bins, "bins", minimum=2)


def check_seed(seed: object) -> int:
    """Return a seed for :func:`numpy.random.default_rng`, a non-negative integer."""
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def check_real(value: object, name: str) -> float:
    """Return ``value`` as a finite float."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(value):
        raise ValueError(f"{name} must be a finite real number, got {value!r}")
    return float(value)


def check_fraction(value: object, name: str) -> float:
    """Return ``value`` as a float strictly between 0 and 1."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0.0 < value < 1.0:
        raise ValueError(f"{name} must be a number in the open interval (0, 1), got {value!r}")
    return float(value)


def check_temperature_range(temperature_range: object) -> tuple[float, float]:
    """Return ``(low, high)`` with ``0 < low < high``, both finite."""
    message = (
        f"temperature_range must be a pair (low, high) of finite numbers with 0 < low < high, got {temperature_range!r}"
    )
    if not isinstance(temperature_range, Sequence | np.ndarray) or len(temperature_range) != 2:
        raise ValueError(message)
    low, high = temperature_range
    for bound in (low, high):
        if isinstance(bound, bool) or not isinstance(bound, numbers.Real) or not np.isfinite(bound):
            raise ValueError(message)
    if not 0.0 < low < high:
        raise ValueError(message)
    return float(low), float(high)
