"""Batched random policies: one forward pass over P policies equals P separate MLPs; every registered family
honours the declared interface of the backends it lists, and is refused by the others."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import torch
import yaml
from gymnasium import spaces

from taskcomplexity.cli import CONF_DIR
from taskcomplexity.config import build
from taskcomplexity.errors import ConfigError
from taskcomplexity.policies import tanh as tanh_module
from taskcomplexity.policies.families import (
    FAMILIES,
    INTERFACES,
    ActingBatch,
    FamilySpec,
    SteppedBatch,
    missing_calls,
    network_from_config,
    sample_family,
)
from taskcomplexity.policies.mlp import NetworkSpec, PriorSpec, policy_parameters, sample_policies, select_policy
from taskcomplexity.rwg import BACKENDS, RWGSettings, run_rwg
from taskcomplexity.rwg.backends import Plan, family_backends, task_backends
from taskcomplexity.stages.keys import stage_key
from taskcomplexity.stages.rwg_stage import NUMERICS, STAGE, RWGRequest
from taskcomplexity.tasks.base import decode_actions
from taskcomplexity.tasks.gym_task import GymTask
from taskcomplexity.tasks.spec import make_task


@pytest.mark.parametrize("network", [NetworkSpec(), NetworkSpec(hidden=(64,), bias=True)])
def test_batched_forward_pass_equals_each_policy_on_its_own(network):
    obs_size, act_size, seed = 10, 2, 3
    indices = np.arange(5, 26)
    batch = sample_policies(network, PriorSpec(), obs_size, act_size, seed, indices)
    x = np.random.default_rng(0).normal(0.0, 2.0, (len(indices), 300, obs_size))
    actions = batch.act(torch.from_numpy(x)).numpy()
    assert actions.shape == (len(indices), 300, act_size)
    for i, n in enumerate(indices):
        h = x[i]
        layers = policy_parameters(network, PriorSpec(), obs_size, act_size, seed, int(n))
        for k, (weight, bias) in enumerate(layers):
            h = h @ weight.T + (0.0 if bias is None else bias)
            h = np.maximum(h, 0.0) if k < len(layers) - 1 else np.tanh(h)
        np.testing.assert_allclose(actions[i], h, rtol=0, atol=1e-12)
        # and the same policy alone, as the PyBullet reference runs it (BLAS may round differently per shape)
        alone = select_policy(batch, i).act(torch.from_numpy(x[i : i + 1, :7])).numpy()
        np.testing.assert_allclose(alone[0], actions[i, :7], rtol=0, atol=1e-12)


def test_the_forward_pass_threads_belong_to_the_batch_and_end_with_it():
    from taskcomplexity.policies import mlp as module

    # no module-global mutable state (a shared pool used to live in one)
    assert not [k for k, v in vars(module).items() if isinstance(v, list | dict | set) and not k.startswith("__")]
    batch = sample_policies(NetworkSpec(), PriorSpec(), 9, 1, 0, np.arange(64))
    x = torch.from_numpy(np.random.default_rng(0).normal(size=(64, 100, 9)))  # 6400 environments: split
    before = set(threading.enumerate())
    with batch:
        split = batch.act(x).numpy()
        started = [t for t in set(threading.enumerate()) - before if t.name.startswith("policy")]
    for thread in started:
        thread.join(timeout=10)
        assert not thread.is_alive()
    if module._workers() > 1:
        assert started  # the work was split over the batch's threads
    np.testing.assert_array_equal(batch.act(x).numpy(), split)  # after close: threads start again
    batch.close()


# -- the original PIC/POIC family (tanh MLPs with a linear output) -----------------------------------
FAMILY = [NetworkSpec(hidden=(), activation="tanh", output="linear"),
          NetworkSpec(hidden=(4,), activation="tanh", output="linear", input_bias=True),
          NetworkSpec(hidden=(64, 64), activation="tanh", output="linear")]
PRIORS = [PriorSpec(), PriorSpec(kind="uniform"), PriorSpec(kind="xavier_normal", gain=5 / 3),
          PriorSpec(kind="xavier_uniform", gain=5 / 3)]


@pytest.mark.parametrize("network", FAMILY)
@pytest.mark.parametrize("prior", PRIORS)
def test_the_original_family_is_a_tanh_mlp_with_a_linear_output_and_an_appended_constant_input(network, prior):
    obs_size, act_size, seed = 3, 2, 9
    indices = np.arange(4)
    batch = sample_policies(network, prior, obs_size, act_size, seed, indices)
    x = np.random.default_rng(1).normal(0.0, 3.0, (len(indices), 50, obs_size))
    outputs = batch.act(torch.from_numpy(x)).numpy()
    for i, n in enumerate(indices):
        layers = policy_parameters(network, prior, obs_size, act_size, seed, int(n))
        h = np.concatenate([x[i], np.ones((50, 1))], axis=1) if network.input_bias else x[i]
        assert layers[0][0].shape[1] == obs_size + int(network.input_bias)
        for k, (weight, bias) in enumerate(layers):
            assert bias is None
            h = h @ weight.T
            h = np.tanh(h) if k < len(layers) - 1 else h  # no output activation
        np.testing.assert_allclose(outputs[i], h, rtol=1e-12, atol=1e-12)


def test_xavier_priors_scale_by_their_gain():
    fan_in, fan_out = 5, 64
    for kind, draw in (("xavier_normal", lambda r, g: r.normal(0.0, g * np.sqrt(2.0 / (fan_in + fan_out)),
                                                               (fan_out, fan_in))),
                       ("xavier_uniform", lambda r, g: r.uniform(-g * np.sqrt(6.0 / (fan_in + fan_out)),
                                                                 g * np.sqrt(6.0 / (fan_in + fan_out)),
                                                                 (fan_out, fan_in)))):
        for gain in (1.0, 5 / 3):
            mine = PriorSpec(kind=kind, gain=gain).draw(np.random.default_rng(4), fan_in, fan_out)
            np.testing.assert_array_equal(mine, draw(np.random.default_rng(4), gain))


def test_a_linear_output_decodes_box_actions_as_high_times_tanh_and_discrete_ones_by_raw_argmax():
    # decode_actions maps (−1, 1) affinely onto [low, high]: for symmetric bounds that is high·t up to one
    # rounding of (t + 1) (|Δ| ≤ 2 ulp(high) in float64), invisible after the float32 cast but for ties.
    batch = sample_policies(FAMILY[0], PriorSpec(), 3, 1, 0, np.arange(1))
    raw = np.random.default_rng(2).normal(0.0, 3.0, (1, 10_000, 1))
    for high in (1.0, 2.0):
        box = spaces.Box(-high, high, (1,), np.float32)
        unit = batch.unit_outputs(raw, box=True).reshape(-1, 1)
        expected = (high * np.tanh(raw.reshape(-1, 1))).astype(np.float32)
        np.testing.assert_allclose(decode_actions(box, unit), expected, rtol=2.0**-23, atol=2.0**-149)
    saturated = np.array([[[20.0, 30.0, -5.0]]])  # tanh ties the first two outputs at 1.0 (argmax 0)
    assert decode_actions(spaces.Discrete(3), batch.unit_outputs(saturated, box=False)[0])[0] == 1
    assert np.tanh(20.0) == np.tanh(30.0) == 1.0


def test_a_network_option_with_zero_units_is_one_line_naming_the_key():
    with pytest.raises(ConfigError, match=r"^network.hidden must be a list of integers >= 1 .*got \[64, 0\]$"):
        build(NetworkSpec, {"hidden": [64, 0], "activation": "tanh"}, "network")
    with pytest.raises(ConfigError, match=r"network.activation must be one of \['relu', 'tanh'\], got 'sigmoid'"):
        build(NetworkSpec, {"activation": "sigmoid"}, "network")
    with pytest.raises(ConfigError, match=r"prior.gain must be > 0, got 0.0"):
        build(PriorSpec, {"kind": "xavier_normal", "gain": 0.0}, "prior")


def test_the_new_fields_at_their_defaults_keep_the_papers_cache_keys(monkeypatch):
    # The paper's keys are those of NumPy's tanh; a process on the tanh kernel (an AVX2 machine) keys its results
    # apart, which tests/policies/test_tanh.py checks: here both kinds of machine check the paper's keys.
    monkeypatch.setattr(tanh_module, "implementation", lambda: tanh_module.NUMPY)
    assert NetworkSpec().identity() == {"hidden": (32, 32), "bias": False}
    assert PriorSpec(kind="uniform").identity() == {"kind": "uniform", "variance": 1.0, "low": -1.0, "high": 1.0}
    request = RWGRequest(make_task("two_link", "dense"), NetworkSpec(hidden=(64, 64)), PriorSpec(),
                         RWGSettings(policies=20, episodes=6, seed=1))
    before = {  # the network and prior as they were hashed before their new fields existed
        "task": request.task.identity(), "network": {"hidden": [64, 64], "bias": False},
        "prior": {"kind": "normal", "variance": 1.0, "low": -1.0, "high": 1.0},
        "policies": 20, "episodes": 6, "seed": 1, "backend": "batched", "common_initial_states": False,
    }
    assert request.key == stage_key(STAGE, NUMERICS, before)
    family = RWGRequest(request.task, FAMILY[2], PriorSpec(kind="xavier_normal", gain=5 / 3), request.settings)
    assert family.identity()["network"]["activation"] == "tanh" and family.identity()["prior"]["gain"] == 5 / 3
    assert family.key != request.key


@pytest.mark.parametrize("name", ["pic_linear", "pic_h1_4", "pic_h1_32", "pic_h1_64", "pic_h2_4", "pic_h2_32",
                                  "pic_h2_64"])
def test_the_family_options_build(name):
    node = yaml.safe_load((CONF_DIR / "network" / f"{name}.yaml").read_text())
    network = build(NetworkSpec, node, "network")
    assert (network.activation, network.output, network.bias, network.input_bias) == ("tanh", "linear", False, False)
    assert len(network.hidden) == (0 if name == "pic_linear" else int(name[5])) and set(network.hidden) <= {4, 32, 64}
    for prior in ("normal", "uniform", "xavier_normal_tanh", "xavier_uniform_tanh"):
        spec = build(PriorSpec, yaml.safe_load((CONF_DIR / "prior" / f"{prior}.yaml").read_text()), "prior")
        assert spec.gain == (5 / 3 if prior.endswith("tanh") else 1.0)


# -- every registered family (docs/how-to/add-a-policy-family.md) --------------------------------------------
TASKS = {"batched": ("one_link_1m0", "dense"), "pybullet": ("one_link_1m0", "dense"), "gym": "CartPole-v1",
         "kernel": "Pendulum-v1", "envpool": "Hopper-v5", "vector": "vector_pendulum:VectorPendulum-v0"}
"""A task per backend: a reaching arm for the arms' backends, a Discrete and a Box classic-control task for
gymnasium's, a MuJoCo task for EnvPool's (skipped without the envpool and mujoco extras), a researcher's vectorised
env (``tests/vector_pendulum.py``) for ``vector``; any other backend gets the first of them it simulates."""
DECLARED = [(name, backend) for name, spec in FAMILIES.items() for backend in family_backends(spec)]
REFUSED = [(name, backend) for name, spec in FAMILIES.items() for backend in BACKENDS
           if backend not in family_backends(spec)]


def _task(backend: str):
    if backend not in TASKS:
        return next(task for task in map(_task, TASKS) if backend in task_backends(task))
    where = TASKS[backend]
    if isinstance(where, tuple):
        return make_task(*where)
    if backend == "envpool":
        pytest.importorskip("envpool", reason="the envpool extra is not installed")
        pytest.importorskip("mujoco", reason="the mujoco extra is not installed")
    return GymTask(where)


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_a_family_is_registered_under_its_name_with_a_config_option_and_backends_rwg_has(name):
    spec = FAMILIES[name]()
    assert isinstance(spec, FamilySpec) and spec.family == name
    assert network_from_config({"family": name}) == spec
    assert family_backends(spec) and set(family_backends(spec)) <= set(BACKENDS), family_backends(spec)
    options = {p.stem: yaml.safe_load(p.read_text()) or {} for p in (CONF_DIR / "network").glob("*.yaml")}
    assert any(node.get("family", "mlp") == name for node in options.values()), f"no network option has family {name}"
    assert isinstance(spec.identity(), dict) and spec.tag and spec.describe()
    assert spec.working_floats(6, 2, 100) > 0


@pytest.mark.parametrize(("name", "backend"), DECLARED)
def test_a_familys_batch_answers_the_calls_of_each_backend_it_runs_on(name, backend):
    """The members the backend calls are there (INTERFACES), ``select`` keeps the sampling indices, and a
    policy is a function of (seed, n) alone: the same sampled alone or among others, to the last bit."""
    task, spec = _task(backend), FAMILIES[name]()
    batch = sample_family(task, spec, PriorSpec(), 3, np.arange(2, 6))
    calls = BACKENDS[backend].calls
    assert missing_calls(batch, calls) == [] and isinstance(batch, INTERFACES[calls])
    assert len(batch) == 4 and list(batch.indices) == [2, 3, 4, 5]
    assert list(batch.select(1).indices) == [3] and len(batch.select(1)) == 1
    some = batch.select(np.array([1, 2]))
    alone = sample_family(task, spec, PriorSpec(), 3, np.array([3, 4]))
    assert list(some.indices) == [3, 4]
    x = torch.from_numpy(np.random.default_rng(0).normal(0.0, 1.0, (2, 5, task.observation_size)))
    with some, alone:
        if isinstance(batch, ActingBatch):
            outputs = some.act(x).numpy()
            assert outputs.shape == (2, 5, task.action_size)
            np.testing.assert_array_equal(outputs, alone.act(x).numpy())
            unit = some.unit_outputs(outputs, True)
            assert unit.shape == outputs.shape and np.all(np.abs(unit) <= 1.0)
        if isinstance(batch, SteppedBatch):
            ours, theirs = some.begin(x), alone.begin(x)
            for _ in range(3):
                (action, ours), (expected, theirs) = some.respond(x, ours), alone.respond(x, theirs)
                assert action.shape == (2, 5, task.action_size) and bool((action.abs() <= 1.0).all())
                np.testing.assert_array_equal(action.numpy(), expected.numpy())


@pytest.mark.parametrize(("name", "backend"), DECLARED)
def test_a_family_runs_rwg_on_each_backend_it_runs_on(name, backend):
    task = _task(backend)
    chunk = run_rwg(task, FAMILIES[name](), PriorSpec(), RWGSettings(policies=3, episodes=2, seed=1, chunk_policies=2),
                    backend)
    assert chunk.returns.shape == (3, 2) and np.isfinite(chunk.returns).all() and list(chunk.policy) == [0, 1, 2]
    assert (chunk.steps >= 1).all()


@pytest.mark.parametrize(("name", "backend"), REFUSED)
def test_a_backend_a_family_does_not_run_on_is_refused_in_one_line_before_any_work(name, backend):
    task, spec = _task(backend), FAMILIES[name]()
    with pytest.raises(ConfigError, match=rf"^network.family={name} cannot run on backend={backend} for task "
                                          rf"{task.task_id}: the family runs on {', '.join(family_backends(spec))}") as err:
        run_rwg(task, spec, PriorSpec(), RWGSettings(policies=2, episodes=2), backend)
    assert "\n" not in str(err.value)


def test_a_batch_without_the_calls_of_a_backend_is_refused_by_name_not_an_attribute_error():
    """A batch handed to a backend whose calls it cannot answer: the backend's missing calls are named."""
    from taskcomplexity.rwg import run_batch

    steps_only = sample_family(make_task("one_link_1m0", "dense"), FAMILIES["dmp"](), PriorSpec(), 0, np.arange(2))
    with pytest.raises(TypeError, match=r"^backend=kernel cannot run a PrimitiveBatch: it lacks act, unit_outputs "
                                        r"\(the backend's calls: taskcomplexity.policies.families.ActingBatch\)$"):
        run_batch(GymTask("Pendulum-v1"), steps_only, "kernel", Plan(seed=0, episodes=2))
