"""The deterministic temperature search of POIC: a coarse log-spaced grid refined around its peaks.

All temperatures the search can visit lie on one fixed log-spaced *lattice*: ``grid_points`` coarse
temperatures over the range, each coarse step subdivided into ``refine_points`` fine steps. The
search evaluates the coarse grid, picks up to ``refine_peaks`` local maxima of the coarse curve
(highest first) and evaluates every lattice point strictly between each peak's two coarse
neighbours. Because the lattice is fixed, the point estimate and every bootstrap resample visit
temperatures from the same finite set, and per-policy work done at a lattice temperature can be
shared between them. The four options are one :class:`POICSearch`, which every estimator that
searches takes as ``search``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from taskcomplexity.metrics._validation import check_int, check_temperature_range

TIE_TOLERANCE = 1e-10
"""Mutual-information values (nats) closer than this count as equal: curves are flat only up to
summation rounding on plateaus (for example at small λ, where MI reaches its limit exactly)."""


@dataclass(frozen=True)
class POICSearch:
    """Options of the POIC temperature search, the defaults being the published search.

    Attributes
    ----------
    temperature_range : (float, float), default (1e-4, 2e4)
        Range ``(low, high)``, ``0 < low < high``, of the temperature λ (return units).
    grid_points : int, default 200
        Coarse log-spaced temperatures over the range (the published random search used 200 trials).
    refine_points : int, default 32
        Fine steps per coarse step in a refined bracket (1 = no refinement); a bracket then holds
        2·32 - 1 = 63 new temperatures.
    refine_peaks : int, default 3
        Coarse local maxima refined, highest first (guards against a second peak of similar height).
    """

    temperature_range: tuple[float, float] = (1e-4, 2e4)
    grid_points: int = 200
    refine_points: int = 32
    refine_peaks: int = 3

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first invalid option, what is allowed and the value received
        (the checks of :meth:`lattice`)."""
        self.lattice()

    def lattice(self) -> TemperatureLattice:
        """The validated options as the lattice the search visits."""
        low, high = check_temperature_range(self.temperature_range)
        return TemperatureLattice(
            low=low,
            high=high,
            grid_points=check_int(self.grid_points, "grid_points", minimum=2),
            refine_points=check_int(self.refine_points, "refine_points", minimum=1),
            refine_peaks=check_int(self.refine_peaks, "refine_peaks", minimum=1),
        )


DEFAULT_SEARCH = POICSearch()
"""The published POIC temperature search (the default ``search`` of the estimators)."""


def check_search(search: object) -> TemperatureLattice:
    """The lattice of ``search``, a valid :class:`POICSearch` (the public ``search`` argument)."""
    if not isinstance(search, POICSearch):
        raise TypeError(f"search must be a POICSearch, got {search!r}")
    return search.lattice()


@dataclass(frozen=True)
class TemperatureLattice:
    """Log-spaced lattice of candidate temperatures λ.

    Attributes
    ----------
    low, high : float
        Ends of the temperature range, ``0 < low < high``.
    grid_points : int
        Number G of coarse temperatures (lattice points ``0, s, 2s, …``), >= 2.
    refine_points : int
        Number s of fine steps per coarse step, >= 1 (1 = no refinement).
    refine_peaks : int
        Number of coarse local maxima refined per curve, >= 1.
    """

    low: float
    high: float
    grid_points: int
    refine_points: int
    refine_peaks: int

    @property
    def size(self) -> int:
        """Number of lattice points, ``(G - 1)·s + 1``."""
        return (self.grid_points - 1) * self.refine_points + 1

    @property
    def temperatures(self) -> np.ndarray:
        """All lattice temperatures, increasing, shape (size,); the ends are exactly low and high."""
        values = np.exp(np.linspace(np.log(self.low), np.log(self.high), self.size))
        values[0], values[-1] = self.low, self.high
        return values

    @property
    def coarse_indices(self) -> np.ndarray:
        """Lattice indices of the coarse grid, shape (G,)."""
        return np.arange(0, self.size, self.refine_points)

    def refinement_mask(self, coarse_curves: np.ndarray) -> np.ndarray:
        """Lattice points each curve's refinement visits besides the coarse grid.

        Parameters
        ----------
        coarse_curves : numpy.ndarray, shape (R, G)
            One curve (mutual information on the coarse grid) per row.

        Returns
        -------
        numpy.ndarray, shape (R, size), bool
            True at the lattice points strictly between the coarse neighbours of each selected
            peak. Peaks are coarse local maxima — not lower than either neighbour and higher than
            at least one, both up to :data:`TIE_TOLERANCE`, so the inside of a plateau is not a
            peak — taken by value, ties by lower temperature.
        """
        curves = np.asarray(coarse_curves, dtype=np.float64)
        step = np.diff(curves, axis=1)
        rises, falls = step > TIE_TOLERANCE, step < -TIE_TOLERANCE
        edge = np.zeros((curves.shape[0], 1), dtype=bool)
        rises_into = np.concatenate((edge, rises), axis=1)
        falls_into = np.concatenate((edge, falls), axis=1)
        rises_after = np.concatenate((rises, edge), axis=1)
        falls_after = np.concatenate((falls, edge), axis=1)
        is_peak = ~falls_into & ~rises_after & (rises_into | falls_after)
        peak_value = np.where(is_peak, curves, -np.inf)
        order = np.argsort(-peak_value, axis=1, kind="stable")[:, : self.refine_peaks]
        valid = np.take_along_axis(peak_value, order, axis=1) > -np.inf

        lattice = np.arange(self.size)
        mask = np.zeros((curves.shape[0], self.size), dtype=bool)
        for peak, is_peak in zip(order.T, valid.T, strict=True):
            centre = peak * self.refine_points
            mask |= (np.abs(lattice[None, :] - centre[:, None]) < self.refine_points) & is_peak[:, None]
        mask[:, self.coarse_indices] = False
        return mask

    def at_boundary(self, index: np.ndarray) -> np.ndarray:
        """Whether lattice indices lie within one fine step of either end of the range."""
        index = np.asarray(index)
        return (index <= 1) | (index >= self.size - 2)
