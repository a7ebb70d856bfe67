"""SAC's objective evaluated directly on the parameters TorchRL's ``SACLoss`` holds: the same loss, less overhead.

:class:`SACObjective` computes what ``SACLoss`` (version 2: no state-value network; fixed α; twin critics;
TD(0) target, :func:`taskcomplexity.rl.factories.make_loss`) computes for the training step, as a few batched
products on the stacked parameters, with the gradients flowing into the same parameter tensors, which the same
optimisers step and the same target updater averages. Per seed s and minibatch transition (o, a, r, o′):

- critic target ``y = r + γ·(1 − terminated)·min_i (Q′_i(o′, a′) − α log π(a′|o′))``, a′ ~ π(·|o′), no gradient;
- critic loss ``Σ_i mean (Q_i(o, a) − y)²`` (or the ``l1``/``smooth_l1`` distance), the mean over seeds and
  transitions;
- actor loss ``mean (α log π(ã|o) − min_i Q_i(o, ã))``, ã ~ π(·|o) reparametrised, the critics' parameters held
  fixed;

and returns ``S × (actor loss + critic loss)`` for S seeds (each seed's gradient is then that of its own mean).
The two critics of the S seeds run as one product over 2·S parameter sets. The actions are drawn from the actor's
own distribution (TanhNormal on the actor's location and scale), in ``SACLoss``'s order (the target's actions
first), so on one generator state the two give the same losses and gradients (``tests/rl/test_objective.py``
allows float32 rounding; on the development machine they are the same bits, and so are whole training runs'
curves). What it saves is ``SACLoss``'s per-update TensorDict bookkeeping and ``vmap`` over the critics
(``bench/bench_sac.py`` times both updates side by side).
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from tensordict.nn import NormalParamExtractor
from torch import nn
from torch.nn import functional
from torchrl.modules import ProbabilisticActor
from torchrl.modules.tensordict_module import SafeProbabilisticModule
from torchrl.objectives import SACLoss
from torchrl.objectives.sac import compute_rsample_log_prob

from taskcomplexity.rl.layers import seed_batched_linear

DISTANCES = {"l2": functional.mse_loss, "l1": functional.l1_loss, "smooth_l1": functional.smooth_l1_loss}
"""The critic's distance to its target, by ``sac.loss_function``."""

Layers = list[tuple[torch.Tensor, torch.Tensor]]


def _layers(params: TensorDictBase, sets: int) -> Layers:
    """(weight, bias) of each linear layer, in order, from a module's parameters (weight then bias per layer),
    each a view with one leading dimension of ``sets`` parameter sets: gradients reach the parameters, and in-place
    updates of them (the target critics' averaging, a checkpoint's loading) reach the views."""
    flat = params.flatten_keys()
    names, tensors = list(flat.keys()), list(flat.values())
    if [n.rpartition(".")[2] for n in names] != ["weight", "bias"] * (len(names) // 2):
        raise ValueError(f"expected a weight and a bias per layer, got {names}")
    pairs = zip(tensors[::2], tensors[1::2], strict=True)
    return [(w.view(sets, *w.shape[-2:]), b.view(sets, *b.shape[-2:])) for w, b in pairs]


def _mlp(layers: Layers, x: torch.Tensor) -> torch.Tensor:
    """The ReLU MLP of ``layers`` on ``x`` (sets, batch, in) → (sets, batch, out)."""
    for index, (weight, bias) in enumerate(layers):
        x = seed_batched_linear(x, weight, bias, bias.shape[-1])
        if index < len(layers) - 1:
            x = torch.relu(x)
    return x


class SACObjective:
    """``S × (actor loss + critic loss)`` of a minibatch (module docstring), on ``loss``'s parameters.

    Parameters
    ----------
    loss : SACLoss
        The loss whose parameters (actor, critics, target critics), α and settings are used; made by
        :func:`~taskcomplexity.rl.factories.make_loss` for ``actor``.
    actor : ProbabilisticActor
        The actor (its scale mapping and distribution are read from it).
    gamma : float
        Discount γ.
    loss_function : {'l2', 'l1', 'smooth_l1'}
    policy_input : nn.Module or None
        Rebuilds the networks' input from (observation, desired goal) for HER; None: the input is ``observation``.

    Notes
    -----
    The parameter views are taken when the objective is made: make it after the parameters are loaded from a
    checkpoint (loading copies into the same tensors, which keeps the views valid, but a replaced tensor would not).
    """

    def __init__(self, loss: SACLoss, actor: ProbabilisticActor, *, gamma: float, loss_function: str,
                 policy_input: nn.Module | None = None):
        self.seeds = next(iter(loss.actor_network_params.flatten_keys().values())).shape[0]
        critics = loss.num_qvalue_nets * self.seeds
        self.actor = _layers(loss.actor_network_params, self.seeds)
        self.critics = _layers(loss.qvalue_network_params, critics)
        self.targets = _layers(loss.target_qvalue_network_params, critics)
        self.num_critics = loss.num_qvalue_nets
        self.extractor = next(m for m in actor.modules() if isinstance(m, NormalParamExtractor))
        sampler = next(m for m in actor.modules() if isinstance(m, SafeProbabilisticModule))
        self.distribution, self.distribution_kwargs = sampler.distribution_class, dict(sampler.distribution_kwargs)
        with torch.no_grad():
            self.alpha = loss.log_alpha.exp()
        self.gamma = gamma
        self.distance = DISTANCES[loss_function]
        self.policy_input = policy_input

    def _input(self, data: TensorDictBase) -> torch.Tensor:
        if self.policy_input is None:
            return data.get("observation")
        return self.policy_input(data.get("observation"), data.get("desired_goal"))

    def _act(self, inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """A reparametrised action and its log-probability, (S, B, n_act) and (S, B)."""
        loc, scale = self.extractor(_mlp(self.actor, inputs))
        return compute_rsample_log_prob(self.distribution(loc, scale, **self.distribution_kwargs))

    def _q(self, layers: Layers, inputs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """Every critic's value, (critics, S, B)."""
        x = torch.cat([inputs, action], dim=-1)
        x = x.unsqueeze(0).expand(self.num_critics, *x.shape).reshape(self.num_critics * self.seeds, *x.shape[1:])
        return _mlp(layers, x).reshape(self.num_critics, self.seeds, -1)

    def __call__(self, batch: TensorDictBase) -> torch.Tensor:
        """The scaled objective of a minibatch of shape (S, B) (its gradient is each seed's own)."""
        nxt = batch.get("next")
        inputs = self._input(batch)
        with torch.no_grad():
            next_action, next_log_prob = self._act(self._input(nxt))
            next_value = (self._q(self.targets, self._input(nxt), next_action) - self.alpha * next_log_prob).min(0)[0]
            reward, terminated = nxt.get("reward").squeeze(-1), nxt.get("terminated").squeeze(-1)
            target = reward + self.gamma * (~terminated).int() * next_value
        predicted = self._q(self.critics, inputs, batch.get("action"))
        critic_loss = self.distance(predicted, target.expand_as(predicted), reduction="none").sum(0).mean()
        action, log_prob = self._act(inputs)
        frozen = [(w.detach(), b.detach()) for w, b in self.critics]
        actor_loss = (self.alpha * log_prob - self._q(frozen, inputs, action).min(0)[0]).mean()
        return (actor_loss + critic_loss) * self.seeds
