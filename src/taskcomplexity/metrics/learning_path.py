"""Learning-path PIC and POIC: the information capacity of policies around the points SAC passes through.

The paper's second proposal. At snapshot k of SAC's actor θ_k, N policies θₙ = θ_k + σεₙ run M
episodes each; PIC_k and POIC_k are the usual estimators on that (N, M) return matrix. The metric is
their mean over the K snapshots of the path: how much the choice of parameters matters *where an
optimiser actually is*, not where a prior puts it.

A :class:`LearningPath` holds one :class:`~taskcomplexity.metrics.sample.Sample` per snapshot. The
perturbed policy n of every snapshot shares its row, so resampling or batching policies takes the
same rows at every k, and a bootstrap draw of the path metric is the mean over k of the draws of
PIC_k (or POIC_k) on the same resampled rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from taskcomplexity.metrics.sample import Sample


@dataclass(frozen=True)
class LearningPath:
    """K return matrices (N, M) of the same policy rows, one per snapshot.

    Attributes
    ----------
    steps : ndarray (K,)
        SAC's environment steps at each snapshot.
    samples : tuple of K Sample
        Returns of the N perturbed policies at each snapshot.
    """

    steps: np.ndarray
    samples: tuple[Sample, ...]

    def __post_init__(self) -> None:
        if not self.samples or len(self.samples) != len(self.steps):
            raise ValueError(f"LearningPath needs one sample per step, got {len(self.samples)} samples for "
                             f"{len(self.steps)} steps")
        if len({s.returns.shape[0] for s in self.samples}) != 1:
            raise ValueError("LearningPath: every snapshot needs the same policies (rows)")

    @property
    def pic(self) -> float:
        """Mean of PIC_k over the path, nats."""
        return float(np.mean([s.pic.pic for s in self.samples]))

    @property
    def poic(self) -> float:
        """Mean of POIC_k over the path, nats."""
        return float(np.mean([s.poic.poic for s in self.samples]))

    def draws(self, metric: str) -> np.ndarray:
        """Bootstrap draws of the path mean of ``metric`` (``pic`` or ``poic``), shape (resamples,)."""
        return np.mean([s.bootstrap[metric].to_numpy() for s in self.samples], axis=0)

    def subsample(self, rows: np.ndarray, *, batch: int | None = None) -> LearningPath:
        return LearningPath(self.steps, tuple(s.subsample(rows, batch=batch) for s in self.samples))

    def curve(self) -> pd.DataFrame:
        """``step, pic, h_r, h_r_given_theta, poic, h_o, h_o_given_theta`` per snapshot."""
        return pd.DataFrame([{"step": int(step), "pic": s.pic.pic, "h_r": s.pic.h_r,
                              "h_r_given_theta": s.pic.h_r_given_theta, "poic": s.poic.poic, "h_o": s.poic.h_o,
                              "h_o_given_theta": s.poic.h_o_given_theta}
                             for step, s in zip(self.steps, self.samples, strict=True)])
