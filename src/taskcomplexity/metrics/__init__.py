"""Task-complexity estimators on a return matrix of random policies.

Every function takes ``returns``, a float array of shape (N, M): row n is policy θₙ, column e is
episode e (N, M >= 2, all finite). Entropies and mutual informations are in nats. The library is
pure numpy/scipy/scikit-learn and prints nothing. ``docs/explanation/estimators.md`` states the
estimators, their formulas and their biases.

Modules
-------
batches
    Welch's t-tests between tasks on per-batch estimates (the paper's significance tests).
bins
    How many bins PIC's histograms take under ``metrics.bins=auto`` (the paper's ratio of returns per bin).
bootstrap
    Fast bootstrap of PIC and POIC over policies.
diagnostics
    Permutation null, bins and subsample sweeps, Miller–Madow and nearest-neighbour MI.
evaluate
    The one place a registered metric is evaluated (points, bootstrap, batches, SAC seeds).
histogram
    Equal-width binning and sparse per-policy histograms.
knn
    Nearest-neighbour mutual information between a label and one continuous variable.
learning_path
    Learning-path PIC and POIC: information capacity around the points SAC's training passes through.
log_mean_exp
    Per-policy log-mean-exp of centred returns (POIC's success probabilities), a numba kernel.
occupancy
    Wasserstein-2 distance between random policies' state–action occupancies and a trained policy's.
pic
    Policy Information Capacity (histogram estimator) and its reference implementation.
poic
    Policy-Optimal Information Capacity and the MI(λ) curve.
policy_tables
    The tables of a stage whose metrics are estimated on a sample of policies beyond the return matrix.
registry
    Every metric declared once: function, labels, unit, direction, family, stage.
resampled_histograms
    Pooled-histogram entropies of many policy resamples at once (the bootstrap PIC's numba kernels).
sac
    Final return, AUC and steps to 90 % of SAC learning curves (inputs of the SAC metrics).
sample
    One return matrix with its estimator settings and shared, lazily computed estimates.
shuffle
    ``Generator.permutation`` of a 1-D array, bit for bit NumPy's, in numba.
statistics
    Per-policy statistics and the normalised random-sampling score.
temperature
    The deterministic temperature search of POIC.
_validation
    Validation of the estimators' public arguments.
"""

import importlib
import sys
import types
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # what the package re-exports, for type checkers and readers; imported on first use (__getattr__)
    from taskcomplexity.metrics.batches import (
        WelchResult,
        format_welch_matrix,
        welch_matrix,
        welch_test,
    )
    from taskcomplexity.metrics.bootstrap import (
        bootstrap,
        bootstrap_indices,
        bootstrap_multiplicities,
        summarise_bootstrap,
    )
    from taskcomplexity.metrics.diagnostics import (
        KNNMIResult,
        KNNOptions,
        permutation_null,
        pic_bins_sweep,
        pic_knn,
        pic_miller_madow,
        pic_subsample_sweep,
        summarise_null,
    )
    from taskcomplexity.metrics.evaluate import batch_estimates, bootstrap_estimates, point_estimates
    from taskcomplexity.metrics.histogram import PolicyBinCounts, bin_edges, plugin_entropy, policy_bin_counts
    from taskcomplexity.metrics.pic import PICResult, pic, pic_reference
    from taskcomplexity.metrics.poic import POICResult, mutual_information_curve, poic
    from taskcomplexity.metrics.registry import DEFAULT_REGISTRY, Detail, Metric, Registry
    from taskcomplexity.metrics.sample import Estimation, Sample
    from taskcomplexity.metrics.statistics import (
        ScoreSummary,
        policy_statistics,
        random_sampling_score,
        validate_returns,
    )
    from taskcomplexity.metrics.temperature import POICSearch

_EXPORTS = {
    "WelchResult": "batches",
    "format_welch_matrix": "batches",
    "welch_matrix": "batches",
    "welch_test": "batches",
    "bootstrap": "bootstrap",
    "bootstrap_indices": "bootstrap",
    "bootstrap_multiplicities": "bootstrap",
    "summarise_bootstrap": "bootstrap",
    "KNNMIResult": "diagnostics",
    "KNNOptions": "diagnostics",
    "permutation_null": "diagnostics",
    "pic_bins_sweep": "diagnostics",
    "pic_knn": "diagnostics",
    "pic_miller_madow": "diagnostics",
    "pic_subsample_sweep": "diagnostics",
    "summarise_null": "diagnostics",
    "batch_estimates": "evaluate",
    "bootstrap_estimates": "evaluate",
    "point_estimates": "evaluate",
    "PolicyBinCounts": "histogram",
    "bin_edges": "histogram",
    "plugin_entropy": "histogram",
    "policy_bin_counts": "histogram",
    "PICResult": "pic",
    "pic": "pic",
    "pic_reference": "pic",
    "POICResult": "poic",
    "mutual_information_curve": "poic",
    "poic": "poic",
    "DEFAULT_REGISTRY": "registry",
    "Detail": "registry",
    "Metric": "registry",
    "Registry": "registry",
    "Estimation": "sample",
    "Sample": "sample",
    "ScoreSummary": "statistics",
    "policy_statistics": "statistics",
    "random_sampling_score": "statistics",
    "validate_returns": "statistics",
    "POICSearch": "temperature",
}
"""Each name the package re-exports → its module: imported on first use (PEP 562), so that reading the registry or
the settings of a stage loads none of the estimators' libraries (pandas, SciPy, scikit-learn, numba)."""


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})


class _Package(types.ModuleType):
    """The package's module: a submodule that shares its name with the function it defines (``pic``, ``poic``,
    ``bootstrap``) leaves the package's name bound to the function when it is imported, as the package's own
    import of the function did."""

    def __setattr__(self, name: str, value) -> None:
        if isinstance(value, types.ModuleType) and _EXPORTS.get(name) == name:
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


__all__ = [
    "DEFAULT_REGISTRY",
    "Detail",
    "Estimation",
    "Metric",
    "Registry",
    "Sample",
    "bootstrap_estimates",
    "point_estimates",
    "KNNMIResult",
    "PICResult",
    "POICResult",
    "POICSearch",
    "PolicyBinCounts",
    "ScoreSummary",
    "WelchResult",
    "batch_estimates",
    "bin_edges",
    "bootstrap",
    "bootstrap_indices",
    "bootstrap_multiplicities",
    "format_welch_matrix",
    "mutual_information_curve",
    "KNNOptions",
    "permutation_null",
    "pic",
    "pic_bins_sweep",
    "pic_knn",
    "pic_miller_madow",
    "pic_reference",
    "pic_subsample_sweep",
    "plugin_entropy",
    "poic",
    "policy_bin_counts",
    "policy_statistics",
    "random_sampling_score",
    "summarise_bootstrap",
    "summarise_null",
    "validate_returns",
    "welch_matrix",
    "welch_test",
]
