"""The policy families RWG samples from: their declared interface, their registry and their sampler.

A family is two classes. Its **spec** (:class:`FamilySpec`) is the frozen dataclass that a ``network``
config node builds (``conf/network/<option>.yaml``; its ``family`` key names the family); it keys the returns,
labels the runs, sizes the chunks and samples a **batch** of policies. The batch answers the calls of the backends
it runs on: every backend calls :class:`FamilyBatch`'s members; a backend that steps a batch (the reaching arms'
``batched`` and ``pybullet``) calls :class:`SteppedBatch`'s ``begin``/``respond``, one that acts through it
(gymnasium's ``gym``, ``kernel``, ``envpool`` and ``vector``) :class:`ActingBatch`'s ``act``/``unit_outputs``
(:data:`INTERFACES`). So the backends a family runs on follow from the class its ``sample`` returns
(:func:`taskcomplexity.rwg.backends.family_backends`).

- ``mlp`` (the default; a config without ``family`` is one): the paper's random MLPs,
  :class:`~taskcomplexity.policies.mlp.NetworkSpec` → :class:`~taskcomplexity.policies.mlp.PolicyBatch`,
  on every backend;
- ``dmp``: the paper's first proposal, a movement primitive per joint of a reaching arm,
  :class:`~taskcomplexity.policies.primitives.PrimitiveSpec` →
  :class:`~taskcomplexity.policies.primitives.PrimitiveBatch`, on the reaching arms' ``batched`` and
  ``pybullet`` backends.

:data:`FAMILIES` maps ``network.family`` to its spec class; :func:`sample_family` samples through the spec.
A backend whose calls a family's batch does not answer is refused before any work
(:func:`taskcomplexity.rwg.backends.resolve_backend`). ``docs/how-to/add-a-policy-family.md`` adds one.

Shapes: P policies of a batch, E environments per policy (episodes run together), ``obs`` the task's
observation size, ``act`` its action size (:class:`~taskcomplexity.tasks.base.Task`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, Self, runtime_checkable

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
    """A batch that a backend steps (``calls="stepped"``: the reaching arms' ``batched`` and ``pybullet``).

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
    """A batch that a backend acts through (``calls="acting"``: gymnasium's ``gym``, ``kernel``, ``envpool``,
    ``vector``): Box or Discrete actions."""

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


INTERFACES: dict[str, type[FamilyBatch]] = {"stepped": SteppedBatch, "acting": ActingBatch}
"""What a backend calls on a batch (its ``calls``, :class:`taskcomplexity.rwg.backends.Backend`) → the interface: a
family runs on the backends whose interface its batch implements."""


def missing_calls(batch: object, calls: str) -> list[str]:
    """The members of the interface ``calls`` (:data:`INTERFACES`) that ``batch`` (a batch or its class) lacks:
    empty if it runs on the backends that make those calls."""
    interface = INTERFACES[calls]
    members = (*FamilyBatch.__annotations__, "__len__", "__enter__", "__exit__",
               *(name for name in dir(interface) if not name.startswith("_")))
    cls = batch if isinstance(batch, type) else type(batch)
    fields = {name for klass in cls.__mro__ for name in getattr(klass, "__annotations__", {})}
    return [name for name in members if not (hasattr(batch, name) or name in fields)]


@runtime_checkable
class FamilySpec(Protocol):
    """The settings of a policy family: a frozen dataclass that a ``network`` config node builds.

    Its fields are the family's options (``network.<field>``); :func:`taskcomplexity.config.build` checks
    their types and calls :meth:`validate`.

    Attributes
    ----------
    family : str
        Its name in :data:`FAMILIES` (``network.family``), the field's default.
    """

    family: str

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
            P policies, ``indices`` as given; a :class:`SteppedBatch`, an :class:`ActingBatch` or both. The method's
            return annotation names the batch's class: the backends the family runs on are those whose calls that
            class answers.
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
