"""Task-complexity estimators on a return matrix of random policies.

Every function takes ``returns``, a float array of shape (N, M): row n is policy θₙ, column e is
episode e (N, M >= 2, all finite). Entropies and mutual informations are in nats. The library is
pure numpy/scipy/scikit-learn and prints nothing.

Modules
-------
statistics   per-policy statistics and the normalised random-sampling score
histogram    equal-width binning and sparse per-policy histograms
pic          Policy Information Capacity (histogram estimator) and its reference implementation
temperature  the deterministic temperature search of POIC
poic         Policy-Optimal Information Capacity and the MI(λ) curve
bootstrap    fast bootstrap of PIC and POIC over policies
batches      Welch's t-tests between tasks
diagnostics  permutation null, bins and subsample sweeps, Miller–Madow and nearest-neighbour MI
sample       one return matrix with its estimator settings and shared, lazily computed estimates
registry     every metric declared once: function, labels, unit, direction, family, stage
evaluate     the one place a registered metric is evaluated (points, bootstrap, batches, SAC seeds)
sac          final return, AUC and steps to 90 % of SAC learning curves (inputs of the SAC metrics)
"""

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
