"""Dynamic movement primitives (DMPs): the inductive-bias policy family of the paper's first proposal.

A discrete DMP (Ijspeert et al., "Dynamical Movement Primitives", Neural Computation 2013) turns a
few weights into a smooth joint trajectory from a start y₀ to a goal g. Per joint, with phase x,

    τ ż = α_z (β_z (g − y) − z) + f(x),     τ ẏ = z,     τ ẋ = −α_x x,  x(0) = 1,
    f(x) = (Σᵢ ψᵢ(x) wᵢ / Σᵢ ψᵢ(x)) · x · (g − y₀),   ψᵢ(x) = exp(−hᵢ (x − cᵢ)²).

With every weight 0 the system is a critically damped spring (β_z = α_z/4) that reaches g smoothly;
the weights shape the way there, and their influence fades with x, so every DMP converges to g.
Random weights drawn from a prior therefore give random but goal-directed movements: the inductive
bias an MLP on raw observations lacks.

Everything here is batched: B primitives (e.g. policies × episodes) of J joints. Time is in seconds;
τ is the movement's duration.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np


@dataclass(frozen=True)
class DMPSpec:
    """The shape of a DMP family.

    Attributes
    ----------
    basis : int
        K, Gaussian basis functions per joint (>= 1).
    alpha_z : float
        Spring gain α_z (> 0); β_z = α_z / 4 makes the spring critically damped.
    alpha_x : float
        Decay of the phase (> 0): x(τ) = e^(−α_x) at the end of the movement.
    substeps : int
        Euler sub-steps of the integration per output step (>= 1).
    """

    basis: int = 10
    alpha_z: float = 25.0
    alpha_x: float = 3.0
    substeps: int = 10

    @property
    def beta_z(self) -> float:
        return self.alpha_z / 4.0

    def validate(self) -> DMPSpec:
        if self.basis < 1 or self.substeps < 1:
            raise ValueError(f"DMPSpec: basis and substeps must be >= 1, got {self.basis}, {self.substeps}")
        if not (self.alpha_z > 0 and self.alpha_x > 0):
            raise ValueError(f"DMPSpec: alpha_z and alpha_x must be > 0, got {self.alpha_z}, {self.alpha_x}")
        return self

    def centres(self) -> np.ndarray:
        """cᵢ (K,): evenly spaced in time over the movement, so in phase x = e^(−α_x t/τ)."""
        return np.exp(-self.alpha_x * np.linspace(0.0, 1.0, self.basis))

    def widths(self) -> np.ndarray:
        """hᵢ (K,) = 1/(cᵢ₊₁ − cᵢ)²: each basis falls to e^(−1/4) of its peak half-way to the next centre."""
        c = self.centres()
        if self.basis == 1:
            return np.array([1.0])
        gaps = np.abs(np.diff(c))
        return 1.0 / np.append(gaps, gaps[-1]) ** 2

    @cached_property
    def _basis(self) -> tuple[np.ndarray, np.ndarray]:
        return self.centres(), self.widths()  # once per spec: the integration calls activations per sub-step

    def activations(self, x: np.ndarray) -> np.ndarray:
        """ψᵢ(x) for phases ``x`` (n,) → (n, K)."""
        centres, widths = self._basis
        return np.exp(-widths * (np.asarray(x)[:, None] - centres) ** 2)

    def forcing(self, x: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Σᵢ ψᵢ(x) wᵢ / Σᵢ ψᵢ(x) · x for phases ``x`` (B,) and ``weights`` (B, J, K) → (B, J)."""
        psi = self.activations(x)  # (B, K)
        psi_sum = psi.sum(axis=1)
        return np.einsum("bk,bjk->bj", psi, weights) / psi_sum[:, None] * np.asarray(x)[:, None]

    def phases(self, n: int, dt: float, duration: float) -> np.ndarray:
        """x at the first ``n`` Euler sub-steps of length ``dt`` (s) from x(0) = 1: (n,).

        The phase depends on time only, so every primitive of a batch shares it (and its basis
        activations): :meth:`rollout` evaluates them once per sub-step, not once per primitive.
        """
        x = np.empty(n)
        value = 1.0
        for i in range(n):
            x[i] = value
            value = value - dt * self.alpha_x * value / duration
        return x

    def rollout(self, weights: np.ndarray, start: np.ndarray, goal: np.ndarray, *, duration: float,
                steps: int, extra_steps: int = 0, repeats: int = 1) -> np.ndarray:
        """Positions y at ``steps`` + 1 equally spaced times over [0, ``duration``] (and ``extra_steps``
        more at the same spacing after it, while the phase fades and the spring holds y at g).

        Parameters
        ----------
        weights : ndarray (B / repeats, J, K)
            Row r drives primitives r·repeats … (r + 1)·repeats − 1 (a policy's episodes share its weights).
        start, goal : ndarray (B, J)
            y₀ and g (joint angles, radians).
        duration : float
            τ, seconds.
        steps : int
            Output steps over τ; each is integrated with ``substeps`` Euler sub-steps.
        extra_steps : int
            Output steps after τ.
        repeats : int
            Primitives per row of ``weights`` (>= 1).

        Returns
        -------
        ndarray (B, steps + extra_steps + 1, J): y(0) = y₀, …, y(τ), ….

        The forcing's basis sum depends on the phase and the weights only, so it is evaluated once per
        sub-step and row of ``weights`` (NumPy, as :meth:`forcing` sums it), and the Euler integration
        of every primitive runs in one parallel numba loop with the same operations in the same order
        as the NumPy expression it replaces: every number is the same to the bit.
        """
        self.validate()
        weights = np.ascontiguousarray(weights, dtype=np.float64)
        start = np.ascontiguousarray(start, dtype=np.float64)
        goal = np.ascontiguousarray(goal, dtype=np.float64)
        if repeats < 1 or weights.shape[0] * repeats != start.shape[0]:
            raise ValueError(f"rollout: {weights.shape[0]} weight rows × repeats={repeats} must equal the "
                             f"{start.shape[0]} primitives of start")
        dt = duration / (steps * self.substeps)
        x = self.phases((steps + extra_steps) * self.substeps, dt, duration)
        psi = self.activations(x)  # (n, K): one row per sub-step, shared by the batch
        psi_sum = psi.sum(axis=1)
        forcing = np.empty((x.size, *weights.shape[:2]))  # (n, B / repeats, J), before × (g − y₀)
        for i in range(x.size):
            forcing[i] = np.einsum("k,bjk->bj", psi[i], weights) / psi_sum[i] * x[i]
        out = np.empty((start.shape[0], steps + extra_steps + 1, start.shape[1]))
        _integrate(forcing, start, goal, repeats, self.substeps, float(self.alpha_z), float(self.beta_z),
                   float(duration), float(dt), out)
        return out

    def fit(self, trajectory: np.ndarray, *, duration: float) -> np.ndarray:
        """Weights (J, K) that reproduce a demonstrated ``trajectory`` (T + 1, J) over [0, duration].

        Locally weighted regression of the forcing term the demonstration needs (its velocity and
        acceleration by finite differences), one basis function at a time.
        """
        y = np.asarray(trajectory, dtype=np.float64)
        t = np.linspace(0.0, duration, len(y))
        yd = np.gradient(y, t, axis=0)
        ydd = np.gradient(yd, t, axis=0)
        start, goal = y[0], y[-1]
        x = np.exp(-self.alpha_x * t / duration)
        # τ²ÿ = α_z(β_z(g − y) − τẏ) + f  ⇒  f needed at every sample
        needed = duration ** 2 * ydd - self.alpha_z * (self.beta_z * (goal - y) - duration * yd)
        psi = self.activations(x)  # (T+1, K)
        s = x[:, None] * (goal - start)  # (T+1, J)
        numerator = np.einsum("tk,tj->jk", psi, s * needed)
        denominator = np.einsum("tk,tj->jk", psi, s * s)
        return numerator / np.where(denominator > 0, denominator, 1.0)


_BLOCK = 256
"""Primitives per parallel job of :func:`_integrate` (one row of weights each): its state stays in L1."""


@numba.njit(cache=True, parallel=True)
def _integrate(forcing, start, goal, repeats, substeps, alpha_z, beta_z, duration, dt, out):
    """Euler integration of every primitive (row b of ``start``, weights row b // repeats) into ``out``.

    Per joint and sub-step i, with f = forcing[i, b // repeats, j] · (g − y₀):
    ``dz = (α_z (β_z (g − y) − z) + f) / τ``, ``dy = z / τ``, then ``z += dt·dz``, ``y += dt·dy``.
    Each job holds up to ``_BLOCK`` primitives of one weight row and advances them together (the
    innermost loop runs over primitives, so it vectorises); no fused multiply-add (numba's default),
    so each operation rounds as NumPy's does.
    """
    rows, joints = start.shape
    steps = out.shape[1] - 1
    blocks = (repeats + _BLOCK - 1) // _BLOCK
    for job in numba.prange((rows // repeats) * blocks):
        r = job // blocks
        lo = r * repeats + (job % blocks) * _BLOCK
        n = min(lo + _BLOCK, (r + 1) * repeats) - lo
        y, z, g, a = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
        for j in range(joints):
            for k in range(n):
                y[k] = start[lo + k, j]
                g[k] = goal[lo + k, j]
                a[k] = g[k] - y[k]
                z[k] = 0.0
                out[lo + k, 0, j] = y[k]
            for step in range(steps):
                for i in range(step * substeps, (step + 1) * substeps):
                    fi = forcing[i, r, j]
                    for k in range(n):
                        dz = (alpha_z * (beta_z * (g[k] - y[k]) - z[k]) + fi * a[k]) / duration
                        dy = z[k] / duration
                        z[k] = z[k] + dt * dz
                        y[k] = y[k] + dt * dy
                for k in range(n):
                    out[lo + k, step + 1, j] = y[k]
