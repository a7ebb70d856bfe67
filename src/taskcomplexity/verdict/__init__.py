"""The verdict: the study's known relations × the registry's metrics → outcomes (a cached stage).

The stage itself (cache key, files) is :mod:`taskcomplexity.stages.verdict_stage`.

Modules
-------
gather
    Tidy values, samples and shown details of every registered metric from the stages' tables.
groups
    A study's ordered difficulty groups: each metric's rank agreement with them, and the relations between groups.
information
    Whether each value carries information (above its permutation null, below its ceiling).
judge
    Every (metric, relation) outcome, per-metric counts, Kendall's τ.
references
    Reference scores (the study's own, Score(A) and Score(R)) and every metric's correlation with them.
replication
    A paper's printed correlations beside ours: reproduced, estimator bias, not reproduced or unresolved.
"""

from taskcomplexity.verdict.gather import gather, gather_details, gather_policies
from taskcomplexity.verdict.information import information, null_means, uninformative
from taskcomplexity.verdict.judge import OUTCOMES, VERDICT_COLUMNS, by_relation, judge, pairwise_welch, summarise

__all__ = ["OUTCOMES", "VERDICT_COLUMNS", "by_relation", "gather", "gather_details", "gather_policies", "information",
           "judge", "null_means", "pairwise_welch", "summarise", "uninformative"]
