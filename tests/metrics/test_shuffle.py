"""The numba permutation is NumPy's Generator.permutation, bit for bit, and leaves the same state."""

from __future__ import annotations

import numpy as np
import pytest

from taskcomplexity.metrics.shuffle import permutation, shuffled_ahead


@pytest.mark.parametrize("size", [0, 1, 2, 3, 17, 1000, 65_537])
@pytest.mark.parametrize("seed", [0, 1, 12345])
def test_same_permutations_and_state_as_numpy(size, seed):
    ours, numpys = np.random.default_rng(seed), np.random.default_rng(seed)
    values = np.linspace(-3.0, 7.0, size)
    for warm_up in (0, 1, 3):  # odd counts of 32-bit draws leave a buffered half-word behind
        ours.integers(0, 7, size=warm_up)
        numpys.integers(0, 7, size=warm_up)
        np.testing.assert_array_equal(permutation(ours, values), numpys.permutation(values))
        assert ours.bit_generator.state == numpys.bit_generator.state
    assert ours.random() == numpys.random()


def test_integer_values_and_other_generators():
    values = np.arange(500, dtype=np.int32)
    np.testing.assert_array_equal(permutation(np.random.default_rng(4), values),
                                  np.random.default_rng(4).permutation(values))
    mt = np.random.Generator(np.random.MT19937(5))  # not PCG64: NumPy does the work
    np.testing.assert_array_equal(permutation(mt, values), np.random.Generator(np.random.MT19937(5)).permutation(values))


def test_the_input_is_not_modified():
    values = np.arange(10.0)
    permutation(np.random.default_rng(0), values)
    np.testing.assert_array_equal(values, np.arange(10.0))


def test_shuffled_ahead_gives_the_in_line_permutations_in_order():
    # Drawn one ahead in a background thread: the same matrices, in the same order, each with what
    # `prepare` made of it, and the generator left where drawing them one after another leaves it.
    returns = np.random.default_rng(1).normal(size=(30, 17))
    in_line, ahead = np.random.default_rng(9), np.random.default_rng(9)
    expected = [in_line.permutation(returns.ravel()).reshape(returns.shape) for _ in range(4)]
    made = list(shuffled_ahead(ahead, returns, 4, prepare=lambda m: m.max(axis=1)))
    assert len(made) == 4
    for (permuted, row_max), reference in zip(made, expected, strict=True):
        np.testing.assert_array_equal(permuted, reference)
        np.testing.assert_array_equal(row_max, reference.max(axis=1))
    assert ahead.bit_generator.state == in_line.bit_generator.state
    assert [p for p, _ in shuffled_ahead(ahead, returns, 0)] == []
    assert all(prepared is None for _, prepared in shuffled_ahead(ahead, returns, 2))
