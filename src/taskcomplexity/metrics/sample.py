"""One return matrix and the settings to estimate on it: what every registered metric reads.

A :class:`Sample` is the whole N × M return matrix of a task, or one consecutive policy batch of it
(``batch`` is then the batch's index). Estimates that several metrics share (the PIC histogram,
the POIC search, the score's bounds, the bootstrap draws, the nearest-neighbour estimate) are
computed once per sample, on first use, and kept on the instance; nothing is shared between
instances.

Seeds of the random components (permutation null, nearest-neighbour subsample) are derived from
one seed (:func:`component_seeds`), and a batch gets its own stream per component
(``batch_<component> + batch``), so that estimating on a batch never replays the whole sample's draws.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import pandas as pd

from taskcomplexity.metrics._validation import validate_returns
from taskcomplexity.metrics.bootstrap import bootstrap
from taskcomplexity.metrics.diagnostics import KNNMIResult, KNNOptions, null_pic, pic_miller_madow
from taskcomplexity.metrics.pic import DEFAULT_BINS, PICResult, pic
from taskcomplexity.metrics.poic import POICResult, PolicyLogMeans, poic
from taskcomplexity.metrics.statistics import ScoreSummary, random_sampling_score
from taskcomplexity.metrics.temperature import DEFAULT_SEARCH, POICSearch

COMPONENTS = ("null", "subsample", "knn", "batch_null", "batch_knn")
"""Random components with their own seed stream (:func:`component_seeds`)."""


def component_seeds(seed: int) -> dict[str, int]:
    """Independent seeds per component, so that changing one component never shifts another's draws."""
    states = np.random.SeedSequence(seed).generate_state(len(COMPONENTS))
    return {name: int(state) for name, state in zip(COMPONENTS, states, strict=True)}


@dataclass(frozen=True)
class Estimation:
    """Settings of every estimator (the stages build it from their configs).

    Attributes
    ----------
    bins : int
        B, histogram bins of PIC and its variants.
    search : POICSearch
        The POIC temperature search.
    resamples : int
        Bootstrap resamples of the policies.
    bootstrap_seed : int
        Seed of the bootstrap.
    null_repeats : int
        Permutations of the null behind ``pic_minus_null``.
    knn_neighbors, knn_max_samples, knn_episodes_per_policy : int
        Options of the nearest-neighbour MI (:func:`~taskcomplexity.metrics.diagnostics.pic_knn`).
    seed : int
        Seed of the random components (:func:`component_seeds`).
    """

    bins: int = DEFAULT_BINS
    search: POICSearch = DEFAULT_SEARCH
    resamples: int = 1000
    bootstrap_seed: int = 0
    null_repeats: int = 10
    knn_neighbors: int = 3
    knn_max_samples: int = 50_000
    knn_episodes_per_policy: int = 50
    seed: int = 0


class Sample:
    """A return matrix (N, M) with lazily computed, shared estimates.

    Parameters
    ----------
    returns : array_like, shape (N, M)
        Episode returns; row n is policy n in sampling order.
    estimation : Estimation
        Estimator settings.
    batch : int, optional
        Index of the policy batch this sample is (None: the whole sample).
    progress : bool, default False
        Show progress bars of long estimates (the bootstrap).
    """

    def __init__(self, returns: object, estimation: Estimation, *, batch: int | None = None,
                 progress: bool = False) -> None:
        self.returns = validate_returns(returns)
        self.estimation = estimation
        self.batch = batch
        self.progress = progress

    def seed(self, component: str) -> int:
        """Seed of ``component`` (one of ``null``, ``knn``) for this sample (whole or batch)."""
        seeds = component_seeds(self.estimation.seed)
        return seeds[component] if self.batch is None else seeds[f"batch_{component}"] + self.batch

    @cached_property
    def pic(self) -> PICResult:
        return pic(self.returns, bins=self.estimation.bins)

    @cached_property
    def log_means(self) -> PolicyLogMeans:
        """Per-policy ℓₙ(λ), shared by the POIC point estimate and its bootstrap."""
        return PolicyLogMeans(self.returns)

    @cached_property
    def poic(self) -> POICResult:
        return poic(self.returns, search=self.estimation.search, log_means=self.log_means)

    @cached_property
    def score(self) -> ScoreSummary:
        return random_sampling_score(self.returns)

    @cached_property
    def pic_miller_madow(self) -> PICResult:
        return pic_miller_madow(self.returns, bins=self.estimation.bins)

    @property
    def knn_options(self) -> KNNOptions:
        """The nearest-neighbour MI's options for this sample (its permutation null uses the same)."""
        e = self.estimation
        return KNNOptions(seed=self.seed("knn"), n_neighbors=e.knn_neighbors, max_samples=e.knn_max_samples,
                          episodes_per_policy=e.knn_episodes_per_policy)

    @cached_property
    def knn(self) -> KNNMIResult:
        return self.knn_options.estimate(self.returns)

    @cached_property
    def null_pic(self) -> np.ndarray:
        """Histogram PIC of ``null_repeats`` permutations of the returns across policies, shape (repeats,), nats."""
        # The same permutations as permutation_null with this seed: draws it computed are reused.
        return null_pic(self.returns, seed=self.seed("null"), repeats=self.estimation.null_repeats,
                        bins=self.estimation.bins)

    @cached_property
    def bootstrap(self) -> pd.DataFrame:
        """Bootstrap draws of PIC and POIC (:func:`~taskcomplexity.metrics.bootstrap.bootstrap`)."""
        e = self.estimation
        return bootstrap(self.returns, seed=e.bootstrap_seed, resamples=e.resamples, bins=e.bins, search=e.search,
                         progress=self.progress, log_means=self.log_means)

    def subsample(self, policies: np.ndarray, *, batch: int | None = None) -> Sample:
        """The sample of the rows ``policies`` (e.g. a batch), with the same settings."""
        return Sample(self.returns[policies], self.estimation, batch=batch)
