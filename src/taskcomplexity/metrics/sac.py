"""The empirical difficulty of each task, derived from SAC learning curves.

``docs/explanation/sac-protocol.md`` § What the curves give the verdict states them.

These are the inputs of the registry's SAC metrics (stage ``sac``); the verdict stage computes them.

The input is the tidy table of the SAC stage: one row per evaluation with columns ``task``,
``variant`` ("sac" or "sac+her"), ``seed``, ``env_step`` and ``eval/return_mean`` (the mean return
of the evaluation episodes, sum of rewards); other columns are ignored. Rows without an evaluation
(``eval/return_mean`` missing) are dropped.

Per run (task, variant, seed):

- **final return**: mean of the last ``final_evaluations`` evaluations (sum of rewards);
- **normalisation**: ``(r - low) / (high - low)`` with the task's bounds. With the random-policy
  bounds of the task (``rwg_bounds``: the worst policy mean r_min and the best episode return
  r_max), ``high`` is ``max(r_max, best SAC evaluation of the task)``, as for score_R in
  ``docs/explanation/estimators.md``, so 0 is the worst random policy's mean and 1 the best return anyone reached;
  normalised values are comparable across tasks with different reward scales. Without them the
  bounds are the task's own curve minimum and maximum (over every variant and seed), which only
  describes the curve's shape;
- **area under the normalised curve** (AUC): the trapezoidal integral of the normalised curve over
  env steps divided by the steps covered, i.e. the mean normalised return over training, ≈ [0, 1];
- **steps to 90 %**: the first evaluated env step at which the return has covered 90 % of the way
  from the first evaluation to the final return, ``r ≥ r_first + 0.9 (r_final − r_first)``; NaN when
  the final return is not above the first (nothing was learned).

:func:`sac_summary` gives mean ± sd (ddof 1) across seeds per (task, variant).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

EVAL_RETURN = "eval/return_mean"
READ_COLUMNS = ("task", "variant", "seed", "env_step", EVAL_RETURN)
"""The columns of the SAC stage's curves (:data:`taskcomplexity.rl.CURVE_COLUMNS`) that this module reads."""
SEED_COLUMNS = (
    "task",
    "variant",
    "seed",
    "evaluations",
    "budget",
    "final_return",
    "final_normalised",
    "auc_normalised",
    "steps_to_90",
)


def evaluations(curves: pd.DataFrame) -> pd.DataFrame:
    """The evaluation rows of a SAC curve table, sorted by (task, variant, seed, env_step).

    Raises
    ------
    ValueError
        If a column of :data:`READ_COLUMNS` is missing.
    """
    missing = [c for c in READ_COLUMNS if c not in curves.columns]
    if missing:
        raise ValueError(f"curves must have columns {list(READ_COLUMNS)}, missing {missing}")
    table = curves.loc[curves[EVAL_RETURN].notna(), list(READ_COLUMNS)]
    return table.sort_values(["task", "variant", "seed", "env_step"], kind="stable").reset_index(drop=True)


def normalisation_bounds(
    curves: pd.DataFrame, rwg_bounds: Mapping[str, tuple[float, float]] | None = None
) -> dict[str, tuple[float, float]]:
    """(low, high) per task for the normalised return (see the module docstring).

    Parameters
    ----------
    curves : pandas.DataFrame
        SAC curves (columns of :data:`READ_COLUMNS`).
    rwg_bounds : mapping of task id to (r_min, r_max), optional
        The task's random-policy worst policy mean and best episode return (sum of rewards).

    Returns
    -------
    dict of task id to (float, float)
        ``high > low`` when the task's returns vary; equal bounds give NaN normalised values.
    """
    table = evaluations(curves)
    bounds = {}
    for task, rows in table.groupby("task", sort=False):
        returns = rows[EVAL_RETURN].to_numpy(dtype=np.float64)
        if rwg_bounds is not None and task in rwg_bounds:
            low, high = rwg_bounds[task]
            bounds[task] = (float(low), float(max(high, returns.max())))
        else:
            bounds[task] = (float(returns.min()), float(returns.max()))
    return bounds


def _normalise(values: np.ndarray, low: float, high: float) -> np.ndarray:
    if not high > low:
        return np.full_like(values, np.nan)
    return (values - low) / (high - low)


def _mean_over_steps(steps: np.ndarray, values: np.ndarray) -> float:
    """Trapezoidal integral of ``values`` over ``steps`` divided by the steps covered."""
    span = steps[-1] - steps[0]
    if not span > 0:
        return float(values[-1])
    return float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(steps)) / span)


def _steps_to_fraction(steps: np.ndarray, returns: np.ndarray, final: float, fraction: float) -> float:
    first = returns[0]
    if not final > first:
        return float("nan")
    reached = np.flatnonzero(returns >= first + fraction * (final - first))
    return float(steps[reached[0]]) if reached.size else float("nan")


def seed_summary(
    curves: pd.DataFrame,
    *,
    rwg_bounds: Mapping[str, tuple[float, float]] | None = None,
    final_evaluations: int = 5,
    fraction: float = 0.9,
) -> pd.DataFrame:
    """Final return, normalised AUC and steps to ``fraction`` of the final return, per run.

    Parameters
    ----------
    curves : pandas.DataFrame
        SAC curves (columns of :data:`READ_COLUMNS`).
    rwg_bounds : mapping of task id to (r_min, r_max), optional
        Random-policy bounds for the normalisation (see the module docstring).
    final_evaluations : int, default 5
        Evaluations averaged into the final return (all of them when a run has fewer).
    fraction : float, default 0.9
        Fraction of the improvement that defines ``steps_to_90``.

    Returns
    -------
    pandas.DataFrame, one row per (task, variant, seed)
        Columns of :data:`SEED_COLUMNS`: ``evaluations`` (count), ``budget`` (last env step),
        ``final_return`` (sum of rewards), ``final_normalised`` and ``auc_normalised``
        (normalised return), ``steps_to_90`` (env steps).
    """
    if isinstance(final_evaluations, bool) or not isinstance(final_evaluations, int) or final_evaluations < 1:
        raise ValueError(f"final_evaluations must be an integer >= 1, got {final_evaluations!r}")
    if not 0 < fraction <= 1:
        raise ValueError(f"fraction must be in (0, 1], got {fraction!r}")
    table = evaluations(curves)
    bounds = normalisation_bounds(table, rwg_bounds)
    rows = []
    for (task, variant, seed), run in table.groupby(["task", "variant", "seed"], sort=False):
        steps = run["env_step"].to_numpy(dtype=np.float64)
        returns = run[EVAL_RETURN].to_numpy(dtype=np.float64)
        final = float(returns[-final_evaluations:].mean())
        normalised = _normalise(returns, *bounds[task])
        auc = _mean_over_steps(steps, normalised)
        rows.append(
            {
                "task": task,
                "variant": variant,
                "seed": seed,
                "evaluations": len(run),
                "budget": int(steps[-1]),
                "final_return": final,
                "final_normalised": float(_normalise(np.array([final]), *bounds[task])[0]),
                "auc_normalised": auc,
                "steps_to_90": _steps_to_fraction(steps, returns, final, fraction),
            }
        )
    return pd.DataFrame(rows, columns=list(SEED_COLUMNS))


def sac_summary(per_seed: pd.DataFrame) -> pd.DataFrame:
    """Mean and sd (ddof 1) across seeds of :func:`seed_summary`, per (task, variant).

    Returns
    -------
    pandas.DataFrame, one row per (task, variant)
        ``task``, ``variant``, ``seeds``, ``budget``, and ``<quantity>_mean`` / ``<quantity>_sd`` for
        ``final_return``, ``final_normalised``, ``auc_normalised`` and ``steps_to_90`` (sd is NaN
        with one seed; ``steps_to_90`` averages the seeds that improved, counted in ``improved``).
    """
    quantities = ("final_return", "final_normalised", "auc_normalised", "steps_to_90")
    rows = []
    for (task, variant), runs in per_seed.groupby(["task", "variant"], sort=False):
        row = {"task": task, "variant": variant, "seeds": len(runs), "budget": int(runs["budget"].max())}
        for quantity in quantities:
            values = runs[quantity].to_numpy(dtype=np.float64)
            values = values[np.isfinite(values)]
            row[f"{quantity}_mean"] = float(values.mean()) if values.size else float("nan")
            row[f"{quantity}_sd"] = float(values.std(ddof=1)) if values.size >= 2 else float("nan")
        row["improved"] = int(np.isfinite(runs["steps_to_90"].to_numpy(dtype=np.float64)).sum())
        rows.append(row)
    return pd.DataFrame(rows)
