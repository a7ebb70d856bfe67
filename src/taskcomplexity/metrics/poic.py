"""Policy-Optimal Information Capacity (POIC) with a deterministic temperature search.

For a temperature λ, policy n "succeeds" with probability
``pₙ(λ) = (1/M) Σ_e exp((S[n, e] - S*)/λ)``; POIC is the largest mutual information
``MI(λ) = h(p̄) - (1/N) Σₙ h(pₙ)`` between the policy index and this binary optimality variable over
λ in a range (``docs/explanation/estimators.md`` § POIC). Entropies are in nats.

Computation
-----------
Write ``pₙ(λ) = exp(ℓₙ(λ) + (mₙ - S*)/λ)`` with ``mₙ = max_e S[n, e]`` and
``ℓₙ(λ) = ln (1/M) Σ_e exp((S[n, e] - mₙ)/λ)`` (a log-mean-exp whose largest term is 1, so no
underflow at small λ). ℓ is the only part that touches all N·M returns and it does not depend on
S*; :class:`PolicyLogMeans` computes it once per temperature and caches it on the search lattice.
Everything after it works on N × (temperatures) arrays, and a population given by policy
multiplicities ``w`` (a bootstrap resample) needs only ``w @ pₙ``: so the point estimate and every
bootstrap resample share one definition and one implementation (:func:`search_poic`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
import pandas as pd
import scipy.special

from taskcomplexity.metrics._validation import check_real, validate_returns
from taskcomplexity.metrics.log_mean_exp import log_mean_exp
from taskcomplexity.metrics.temperature import (
    DEFAULT_SEARCH,
    TIE_TOLERANCE,
    POICSearch,
    TemperatureLattice,
    check_search,
)

_LOG_P_FLOOR = -700.0
"""Smallest ln pₙ used; e^-700 ≈ 1e-304 is still a normal float64."""
_TINY = 1e-300
"""Floor inside ln q, so that q ln q is 0 for q = 0."""

@dataclass(frozen=True)
class POICResult:
    """A POIC estimate, where the maximum was found, and its entropy terms.

    Attributes
    ----------
    poic : float
        max over the searched temperatures of MI(λ), in nats (between 0 and ln 2).
    temperature : float
        λ* where the maximum was found (return units).
    at_boundary : bool
        True when λ* lies within one fine lattice step of either end of the temperature range: the
        supremum may then lie outside the range.
    h_o : float
        H(O) = h(p̄(λ*)) in nats.
    h_o_given_theta : float
        H(O|Θ) = (1/N) Σₙ h(pₙ(λ*)) in nats.
    s_star : float
        The reference return S* (best return in the sample, or the supplied optimal return if
        higher).
    """

    poic: float
    temperature: float
    at_boundary: bool
    h_o: float
    h_o_given_theta: float
    s_star: float


@dataclass(frozen=True, eq=False)
class OptimalityCurves:
    """MI(λ), H(O) and H(O|Θ) of R populations at C temperatures, each of shape (R, C), nats."""

    mi: np.ndarray
    h_o: np.ndarray
    h_o_given_theta: np.ndarray


class PolicyLogMeans:
    """Per-policy log-mean-exp ℓₙ(λ) of a return matrix, cached on a temperature lattice.

    Parameters
    ----------
    returns : numpy.ndarray, shape (N, M)
        Validated returns.

    Attributes
    ----------
    row_max : numpy.ndarray, shape (N,)
        Best return mₙ of each policy.

    Notes
    -----
    Each policy's centred returns are sorted once, in decreasing order. When at least half of the
    returns repeat within their policy (integer-valued sparse rewards), each policy's distinct
    returns are stored once with their multiplicities, which makes every evaluation proportionally
    cheaper. ℓ is evaluated by the numba kernel of :mod:`taskcomplexity.metrics.log_mean_exp`
    (exact up to a relative error of the sum bounded there by about 1e-13, typically 1e-16), and
    each ℓₙ depends on policy n's returns alone.
    """

    def __init__(self, returns: np.ndarray) -> None:
        self.row_max = returns.max(axis=1)
        n_policies, self._n_episodes = returns.shape
        ordered = np.sort(returns - self.row_max[:, None], axis=1)[:, ::-1]
        distinct = np.ones(ordered.shape, dtype=bool)
        np.not_equal(ordered[:, 1:], ordered[:, :-1], out=distinct[:, 1:])
        if distinct.sum() <= distinct.size // 2:
            flat_starts = np.flatnonzero(distinct)
            self._values = np.ascontiguousarray(ordered).ravel()[flat_starts]
            self._weights = np.diff(np.append(flat_starts, ordered.size)).astype(np.float64)
            self._indptr = np.zeros(n_policies + 1, dtype=np.int64)
            np.cumsum(distinct.sum(axis=1), out=self._indptr[1:])
        else:
            self._values = np.ascontiguousarray(ordered).ravel()
            self._weights = np.empty(0)
            self._indptr = np.arange(n_policies + 1, dtype=np.int64) * self._n_episodes
        self._cache: dict[float, np.ndarray] = {}

    @property
    def n_policies(self) -> int:
        """Number of policies N."""
        return self.row_max.size

    @property
    def n_episodes(self) -> int:
        """Number of episodes per policy M."""
        return self._n_episodes

    def evaluate(self, temperatures: np.ndarray) -> np.ndarray:
        """ℓₙ(λ) for every policy and temperature, shape (N, T), in [-ln M, 0]."""
        return log_mean_exp(self._values, self._weights, self._indptr, self._n_episodes,
                            np.asarray(temperatures, dtype=np.float64))

    def on_lattice(self, lattice: TemperatureLattice, indices: np.ndarray) -> np.ndarray:
        """ℓ at the given lattice indices, shape (N, len(indices)); each temperature is computed once."""
        temperatures = [float(t) for t in lattice.temperatures[np.asarray(indices, dtype=np.intp)]]
        missing = list(dict.fromkeys(t for t in temperatures if t not in self._cache))
        if missing:
            values = self.evaluate(np.array(missing))
            values.flags.writeable = False  # its columns are the cache
            for column, temperature in enumerate(missing):
                self._cache[temperature] = values[:, column]
            if missing == temperatures:  # all new, in order: no copy
                return values
        if not temperatures:
            return np.empty((self.n_policies, 0))
        return np.stack([self._cache[t] for t in temperatures], axis=1)


def optimality_curves(
    log_means: np.ndarray,
    row_max: np.ndarray,
    temperatures: np.ndarray,
    weights: np.ndarray,
    s_star: np.ndarray,
    needed: np.ndarray | None = None,
) -> OptimalityCurves:
    """MI(λ), H(O) and H(O|Θ) of populations given as policy multiplicities.

    Parameters
    ----------
    log_means : numpy.ndarray, shape (N, C)
        ℓₙ(λ) at C temperatures (from :class:`PolicyLogMeans`).
    row_max : numpy.ndarray, shape (N,)
        Best return mₙ of each policy.
    temperatures : numpy.ndarray, shape (C,)
        The temperatures of the columns of ``log_means``.
    weights : numpy.ndarray, shape (R, N)
        Multiplicity of each policy in each of R populations; each row sums to the population
        size (N for a bootstrap resample, a row of ones for the sample itself).
    s_star : numpy.ndarray, shape (R,)
        Reference return S* of each population.
    needed : numpy.ndarray, shape (R, C), bool, optional
        The temperatures each population needs (None: all). The populations sharing an S* are
        computed at the temperatures any of them needs, the others are NaN.

    Returns
    -------
    OptimalityCurves
        Arrays of shape (R, C).

    Notes
    -----
    Each population's sums are one matrix product of its group's multiplicities with per-policy
    terms at the group's temperatures, so they depend (in the last bits, through the BLAS's blocking)
    on which temperatures the group computes; with ``needed`` None, or a single population, all of them.
    """
    weights = np.asarray(weights, dtype=np.float64)
    n_policies, n_temperatures = log_means.shape
    shape = (weights.shape[0], n_temperatures)
    curves = OptimalityCurves(np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, np.nan))
    values, group = np.unique(s_star, return_inverse=True)
    for label, reference in enumerate(values):
        rows = np.flatnonzero(group.ravel() == label)
        columns = np.arange(n_temperatures) if needed is None else np.flatnonzero(needed[rows].any(axis=0))
        if columns.size == 0:
            continue
        # Per policy and temperature: p, 1 - p and h(p) side by side (_policy_terms), so that one matrix
        # product with the multiplicities gives all three population sums.
        per_policy = np.empty((n_policies, 3, columns.size))
        _policy_terms(log_means, row_max, temperatures, columns, float(reference), per_policy)
        w = weights[rows]
        sums = (w @ per_policy.reshape(n_policies, -1)) / w.sum(axis=1, keepdims=True)
        p_bar, q_bar, h_given = np.split(sums, 3, axis=1)
        h_o = -scipy.special.xlogy(p_bar, p_bar) - scipy.special.xlogy(q_bar, q_bar)
        at = np.ix_(rows, columns)
        curves.h_o[at] = h_o
        curves.h_o_given_theta[at] = h_given
        curves.mi[at] = h_o - h_given
    return curves


@numba.njit(cache=True, inline="always")
def _terms(log_p):
    """``(p, 1 - p, h(p))`` from ``ln p`` in ``[-700, 0]`` (see :func:`_policy_terms`)."""
    p = math.exp(log_p)
    q = -math.expm1(log_p)
    return p, q, -(p * log_p + math.log(max(q, _TINY)) * q)


@numba.njit(cache=True, parallel=True, nogil=True)
def _policy_terms(log_means, row_max, temperatures, columns, reference, out):
    """``out[n, :, j] = (pₙ, 1 - pₙ, h(pₙ))`` at the temperature of column ``columns[j]`` for the reference S*.

    ``ln pₙ = ℓₙ + (mₙ - S*)/λ``, clipped to ``[-700, 0]``: pₙ <= 1 removes rounding excess and keeps
    policies absent from a population (weight 0, possibly mₙ > S*) finite; raising pₙ < e^-700
    (1e-304) to e^-700 moves MI by less than 1e-300 nats and keeps subnormal numbers, slow in exp
    and in matrix products, out of the computation. ``1 - p = -expm1(ln p)`` keeps its precision
    near p = 1, and ``h = -p ln p - q ln q`` uses the exact ln p with ``0 ln 0 = 0`` for q = 0.
    The floor's terms (every policy far below S* at small λ) are computed once.
    """
    low_p, low_q, low_h = _terms(_LOG_P_FLOOR)
    for n in numba.prange(log_means.shape[0]):
        shift = row_max[n] - reference
        for j in range(columns.size):
            c = columns[j]
            log_p = min(max(log_means[n, c] + shift / temperatures[c], _LOG_P_FLOOR), 0.0)
            if log_p == _LOG_P_FLOOR:
                p, q, h = low_p, low_q, low_h
            else:
                p, q, h = _terms(log_p)
            out[n, 0, j] = p
            out[n, 1, j] = q
            out[n, 2, j] = h


@dataclass(frozen=True, eq=False)
class SearchResult:
    """Outcome of :func:`search_poic` for R populations; every array has shape (R,)."""

    poic: np.ndarray
    lattice_index: np.ndarray
    temperature: np.ndarray
    at_boundary: np.ndarray
    h_o: np.ndarray
    h_o_given_theta: np.ndarray


def search_poic(
    source: PolicyLogMeans,
    lattice: TemperatureLattice,
    weights: np.ndarray,
    s_star: np.ndarray,
) -> SearchResult:
    """Maximise MI(λ) over the lattice search for R populations at once.

    Parameters
    ----------
    source : PolicyLogMeans
        Per-policy log-mean-exp of the return matrix the populations draw from.
    lattice : TemperatureLattice
        The temperature search.
    weights : numpy.ndarray, shape (R, N)
        Policy multiplicities of each population.
    s_star : numpy.ndarray, shape (R,)
        Reference return S* of each population.

    Returns
    -------
    SearchResult
        The maximum over every lattice point the population's own search visited (the coarse
        grid and the refinements around its own coarse peaks); among values within
        :data:`TIE_TOLERANCE` of the maximum the lowest temperature wins, and POIC, H(O) and
        H(O|Θ) are reported at that temperature.
    """
    temperatures = lattice.temperatures
    coarse = lattice.coarse_indices
    weights = np.asarray(weights, dtype=np.float64)
    coarse_curves = optimality_curves(
        source.on_lattice(lattice, coarse), source.row_max, temperatures[coarse], weights, s_star
    )
    refine = lattice.refinement_mask(coarse_curves.mi)
    fine = np.flatnonzero(refine.any(axis=0))
    # A population needs only its own brackets: each group of equal S* is computed at their union.
    fine_curves = optimality_curves(
        source.on_lattice(lattice, fine), source.row_max, temperatures[fine], weights, s_star, refine[:, fine]
    )

    columns = np.concatenate((coarse, fine))
    order = np.argsort(columns, kind="stable")
    visited = np.concatenate((np.ones((weights.shape[0], coarse.size), dtype=bool), refine[:, fine]), axis=1)
    mi = np.where(visited, np.concatenate((coarse_curves.mi, fine_curves.mi), axis=1), -np.inf)[:, order]
    # A plateau (for example small λ on integer returns, where MI reaches its limit exactly) is
    # flat only up to summation rounding; treat values within TIE_TOLERANCE of the maximum as tied
    # so that λ* is the plateau's lowest temperature whatever the summation order.
    best = np.argmax(mi >= mi.max(axis=1, keepdims=True) - TIE_TOLERANCE, axis=1)
    rows = np.arange(weights.shape[0])
    h_o = np.concatenate((coarse_curves.h_o, fine_curves.h_o), axis=1)[:, order]
    h_given = np.concatenate((coarse_curves.h_o_given_theta, fine_curves.h_o_given_theta), axis=1)[:, order]
    lattice_index = columns[order][best]
    return SearchResult(
        poic=mi[rows, best],
        lattice_index=lattice_index,
        temperature=temperatures[lattice_index],
        at_boundary=lattice.at_boundary(lattice_index),
        h_o=h_o[rows, best],
        h_o_given_theta=h_given[rows, best],
    )


def shared_log_means(returns: np.ndarray, log_means: PolicyLogMeans | None) -> PolicyLogMeans:
    """``log_means`` after checking that it belongs to ``returns``, or a new ``PolicyLogMeans(returns)``."""
    if log_means is None:
        return PolicyLogMeans(returns)
    if not isinstance(log_means, PolicyLogMeans) or not (
        log_means.n_policies == returns.shape[0] and log_means.n_episodes == returns.shape[1]
        and np.array_equal(log_means.row_max, returns.max(axis=1))
    ):
        raise ValueError("log_means must be PolicyLogMeans(returns) of the same returns")
    return log_means


def reference_return(returns: np.ndarray, optimal_return: float | None) -> float:
    """S*: the best return in ``returns``, or ``optimal_return`` when that is higher."""
    best = float(returns.max())
    if optimal_return is None:
        return best
    return max(best, check_real(optimal_return, "optimal_return"))


def poic(
    returns: object,
    *,
    search: POICSearch = DEFAULT_SEARCH,
    optimal_return: float | None = None,
    log_means: PolicyLogMeans | None = None,
) -> POICResult:
    """Policy-Optimal Information Capacity with a deterministic temperature search.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n, column e is episode e. N, M >= 2, all finite.
    search : POICSearch, default POICSearch()
        The temperature search: range, coarse grid points, fine steps per coarse step and number
        of refined peaks (see :class:`~taskcomplexity.metrics.temperature.POICSearch`).
    optimal_return : float, optional
        A known optimal return; S* becomes ``max(optimal_return, max S)``.
    log_means : PolicyLogMeans, optional
        ``PolicyLogMeans(returns)`` made earlier: the ℓₙ(λ) it has cached are reused and those
        computed now stay cached (for example for the bootstrap of the same returns).

    Returns
    -------
    POICResult
        POIC and λ* (values within :data:`TIE_TOLERANCE` of the maximum count as tied and the
        lowest tied temperature wins), the boundary flag, H(O), H(O|Θ) and S*.

    Notes
    -----
    The search is a fixed function of the data: the coarse grid, then every point of the fine
    lattice strictly inside the two coarse steps around each refined peak (see
    :class:`~taskcomplexity.metrics.temperature.TemperatureLattice`). With the defaults the fine
    step is a factor 1.003 in λ.
    """
    returns = validate_returns(returns)
    lattice = check_search(search)
    s_star = reference_return(returns, optimal_return)
    source = shared_log_means(returns, log_means)
    found = search_poic(source, lattice, np.ones((1, returns.shape[0])), np.array([s_star]))
    return POICResult(
        poic=float(found.poic[0]),
        temperature=float(found.temperature[0]),
        at_boundary=bool(found.at_boundary[0]),
        h_o=float(found.h_o[0]),
        h_o_given_theta=float(found.h_o_given_theta[0]),
        s_star=s_star,
    )


def mutual_information_curve(
    returns: object, temperatures: object, *, optimal_return: float | None = None
) -> pd.DataFrame:
    """MI(λ), H(O) and H(O|Θ) at the given temperatures.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n.
    temperatures : array_like, shape (T,)
        Positive finite temperatures λ (return units).
    optimal_return : float, optional
        A known optimal return; S* becomes ``max(optimal_return, max S)``.

    Returns
    -------
    pandas.DataFrame, T rows
        ``temperature``, ``mi``, ``h_o``, ``h_o_given_theta`` (nats), in the order given.
    """
    returns = validate_returns(returns)
    temperatures = np.asarray(temperatures, dtype=np.float64)
    if temperatures.ndim != 1 or temperatures.size == 0 or not np.all(np.isfinite(temperatures) & (temperatures > 0)):
        raise ValueError(
            "temperatures must be a non-empty 1-D array of positive finite numbers, "
            f"got {np.array2string(temperatures, threshold=6)}"
        )
    source = PolicyLogMeans(returns)
    s_star = reference_return(returns, optimal_return)
    curves = optimality_curves(
        source.evaluate(temperatures),
        source.row_max,
        temperatures,
        np.ones((1, returns.shape[0])),
        np.array([s_star]),
    )
    return pd.DataFrame(
        {
            "temperature": temperatures,
            "mi": curves.mi[0],
            "h_o": curves.h_o[0],
            "h_o_given_theta": curves.h_o_given_theta[0],
        }
    )
