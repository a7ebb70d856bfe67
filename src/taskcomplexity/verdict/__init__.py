"""The verdict: the study's known relations × the registry's metrics → outcomes (a cached stage).

Modules
-------
judge       every (metric, relation) outcome, per-metric counts, Kendall's τ
references  reference scores (the study's own, Score(A) and Score(R)) and every metric's correlation with them
gather      tidy values, samples and shown details of every registered metric from the stages' tables

The stage itself (cache key, files) is :mod:`taskcomplexity.stages.verdict_stage`.
"""

from taskcomplexity.verdict.gather import gather, gather_details
from taskcomplexity.verdict.judge import OUTCOMES, VERDICT_COLUMNS, by_relation, judge, pairwise_welch, summarise

__all__ = ["OUTCOMES", "VERDICT_COLUMNS", "by_relation", "gather", "gather_details", "judge", "pairwise_welch",
           "summarise"]
