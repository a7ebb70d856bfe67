"""The policy families RWG samples from: their declared interface, their registry and their sampler.

A family is two classes. Its **spec** (:class:`FamilySpec`) is the frozen dataclass that a ``network``
config node builds (``conf/network/<option>.yaml``; its ``family`` key names the family); it keys the returns,
labels the runs, sizes the chunks, names the backends it runs on and samples a **batch** of policies. The batch
answers the calls of those backends: every backend calls :class:`FamilyBatch`'s members; the ``batched`` and
``pybullet`` backends step it with :class:`SteppedBatch`'s ``begin``/``respond``, the ``gym``, ``kernel``,
``envpool`` and ``vector`` backends with :class:`ActingBatch`'s ``act``/``unit_outputs`` (:data:`BACKEND_CALLS`).

- ``mlp`` (the default; a config without ``family`` is one): the paper's random MLPs,
  :class:`~taskcomplexity.policies.mlp.NetworkSpec` → :class:`~taskcomplexity.policies.mlp.PolicyBatch`,
  on every backend;
- ``dmp``: the paper's first proposal, a movement primitive per joint of a reaching arm,
  :class:`~taskcomplexity.policies.primitives.PrimitiveSpec` →
  :class:`~taskcomplexity.policies.primitives.PrimitiveBatch`, on the reaching arms' ``batched`` and
  ``pybullet`` backends.

:data:`FAMILIES` maps ``network.family`` to its spec class; :func:`sample_family` samples through the spec.
A backend that a family does not list is refused before any work
(:func:`taskcomplexity.rwg.backends.resolve_backend`). ``docs/how-to/add-a-policy-family.md`` adds one.

Shapes: P policies of a batch, E environments per policy (episodes run together), ``obs`` the task's
observation size, ``act`` its action size (:class:`~taskcomplexity.tasks.base.Task`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar, Protocol, Self, runtime_checkable

import numpy as np

from taskcomplexity.config import build, plain
from taskcomplexity.errors import ConfigError
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec
from taskcomplexity.policies.primitives import PrimitiveSpec

if TYPE_CHECKING:
    import torch


@runtime_checkable
class EpisodeState(Protocol):
    """What a batch remembers of its running episodes between two steps (a family that keeps nothing uses None).

    The ``batched`` backend hands the obstacle task's episodes that reach the block over to PyBullet in
    mid-episode; each continues with the state of its own episode, cut out by :meth:`row`.
    """

    def row(self, p: int, e: int) -> EpisodeState:
        """Episode ``e`` of policy ``p`` alone, as the state of a (1, 1) batch."""
        ...


@runtime_checkable
class FamilyBatch(Protocol):
    """P sampled policies of one family: what every RWG backend calls.

    Attributes
    ----------
    indices : ndarray (P,) int
        The sampling index n of each policy: policy n's episodes start from the reset streams (seed, n, e),
        and the returns are reported under n.
    """

    indices: np.ndarray

    def __len__(self) -> int:
        """P."""
        ...

    def select(self, rows: int | np.ndarray | slice) -> Self:
        """The policies at positions ``rows`` as a batch of their own (an int: a batch of one), with their
        ``indices``. The PyBullet paths run one policy at a time; the ``kernel`` backend drops the policies
        whose episodes have all ended."""
        ...

    def close(self) -> None:
        """Release what the batch holds (e.g. the threads of its forward pass); it may be used again after."""
        ...

    def __enter__(self) -> Self: ...

    def __exit__(self, *exc: object) -> None:
        """:meth:`close`."""
        ...


@runtime_checkable
class SteppedBatch(FamilyBatch, Protocol):
    """A batch the ``batched`` and ``pybullet`` backends step: the reaching arms' backends.

    Both take actions in the arms' units, one per joint in [−1, 1] (× the arm's torque scale, N·m).
    """

    def begin(self, observations: torch.Tensor) -> EpisodeState | None:
        """The state of new episodes from their first observations.

        Parameters
        ----------
        observations : Tensor (P, E, obs) float64
            E episodes per policy, in the task's observation units.

        Returns
        -------
        EpisodeState or None
            None for a family that acts on each observation alone.
        """
        ...

    def respond(self, observations: torch.Tensor,
                state: EpisodeState | None) -> tuple[torch.Tensor, EpisodeState | None]:
        """Every running episode's action and the state of the next step.

        Parameters
        ----------
        observations : Tensor (P, E, obs) float64
        state : EpisodeState or None
            What :meth:`begin` or the previous :meth:`respond` returned.

        Returns
        -------
        actions : Tensor (P, E, act) float64
            In [−1, 1].
        state : EpisodeState or None
        """
        ...


@runtime_checkable
class ActingBatch(FamilyBatch, Protocol):
    """A batch gymnasium's backends (``gym``, ``kernel``, ``envpool``, ``vector``) run: Box or Discrete actions."""

    def act(self, observations: torch.Tensor) -> torch.Tensor:
        """Deterministic outputs, one row per (policy, environment).

        Parameters
        ----------
        observations : Tensor (P, E, obs) float64
            Observations encoded for a policy (Box flattened, Discrete one-hot:
            :func:`taskcomplexity.tasks.base.encode_observations`).

        Returns
        -------
        Tensor (P, E, act) float64
            Raw outputs; :meth:`unit_outputs` says how the backend reads them.
        """
        ...

    def unit_outputs(self, outputs: np.ndarray, box: bool) -> np.ndarray:
        """The outputs of :meth:`act` as the backend decodes them.

        Parameters
        ----------
        outputs : ndarray (P, E, act) float64
        box : bool
            Whether the action space is a Box: the result must then lie in [−1, 1], mapped affinely onto
            [low, high]; a Discrete action is the argmax of the result
            (:func:`taskcomplexity.tasks.base.decode_actions`).

        Returns
        -------
        ndarray (P, E, act) float64
        """
        ...


BACKEND_CALLS: dict[str, type[FamilyBatch]] = {
    "batched": SteppedBatch, "pybullet": SteppedBatch, "gym": ActingBatch, "kernel": ActingBatch,
    "envpool": ActingBatch, "vector": ActingBatch,
}
"""RWG backend → the interface it calls on a batch: a family that lists a backend implements its interface."""


def missing_calls(batch: object, backend: str) -> list[str]:
    """The members of ``backend``'s interface (:data:`BACKEND_CALLS`) that ``batch`` lacks: empty if it can run."""
    interface = BACKEND_CALLS[backend]
    called = (*FamilyBatch.__annotations__, "__len__", "__enter__", "__exit__",
              *(name for name in dir(interface) if not name.startswith("_")))
    return [name for name in called if not hasattr(batch, name)]


@runtime_checkable
class FamilySpec(Protocol):
    """The settings of a policy family: a frozen dataclass that a ``network`` config node builds.

    Its fields are the family's options (``network.<field>``); :func:`taskcomplexity.config.build` checks
    their types and calls :meth:`validate`.

    Attributes
    ----------
    family : str
        Its name in :data:`FAMILIES` (``network.family``), the field's default.
    backends : tuple of str
        The RWG backends that can run its batches (a class variable), each one's interface implemented by
        the batch (:data:`BACKEND_CALLS`). A backend outside it is refused before any work.
    """

    family: str
    backends: ClassVar[tuple[str, ...]]

    def validate(self) -> None:
        """Raise :class:`~taskcomplexity.errors.ConfigError` naming ``network.<field>``, the value and what is
        allowed for a bad option."""
        ...

    def identity(self) -> dict:
        """The fields that key the returns (hashed into the RWG cache key)."""
        ...

    @property
    def tag(self) -> str:
        """Short name in run labels, e.g. ``mlp32x32``."""
        ...

    def describe(self) -> str:
        """The family in words (the report's methods box)."""
        ...

    def working_floats(self, observation_size: int, action_size: int, max_steps: int) -> int:
        """Floats one environment holds while a batch runs it (sizes the ``batched`` backend's chunks)."""
        ...

    def sample(self, task: Any, prior: PriorSpec, seed: int, indices: np.ndarray) -> FamilyBatch:
        """θₙ for every n in ``indices``, drawn from ``prior`` for ``task``.

        Parameters
        ----------
        task : Task
            Its ``observation_size``, ``action_size`` and ``max_steps`` size the policies.
        prior : PriorSpec
            The distribution of the parameters.
        seed : int
            Run seed: θₙ comes from :func:`taskcomplexity.seeding.policy_generator` (seed, n) alone, so a
            policy does not depend on the chunk it is sampled in.
        indices : ndarray (P,) int

        Returns
        -------
        FamilyBatch
            P policies, ``indices`` as given; a :class:`SteppedBatch`, an :class:`ActingBatch` or both, as
            its ``backends`` need.
        """
        ...


FAMILIES: dict[str, type[FamilySpec]] = {
    "mlp": NetworkSpec,
    "dmp": PrimitiveSpec,
}
"""``network.family`` → the dataclass of its settings, the one place a family is registered."""


def network_from_config(node: Any, key: str = "network") -> FamilySpec:
    """The spec of a ``network`` config node, of the family its ``family`` key names (``mlp`` without one)."""
    node = plain(node)
    if isinstance(node, tuple(FAMILIES.values())):
        return node
    family = node.get("family", "mlp") if hasattr(node, "get") else "mlp"
    if family not in FAMILIES:
        raise ConfigError(f"{key}.family must be one of {list(FAMILIES)}, got {family!r}")
    return build(FAMILIES[family], node, key)


def sample_family(task, network: FamilySpec, prior: PriorSpec, seed: int, indices: np.ndarray) -> FamilyBatch:
    """θₙ for every n in ``indices`` on ``task``, from the family ``network`` belongs to (its own sampler)."""
    return network.sample(task, prior, seed, indices)
