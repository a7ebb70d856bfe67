"""The contact model's one-sweep rates against a new measurement on PyBullet (rwg/contact_calibration.py).

``make calibrate-contacts`` prints the same measurement (N = 300 × M = 5, seed 0) beside the constants.
"""

from __future__ import annotations

import pytest

from taskcomplexity.rwg.contact_calibration import measure_single_sweep_rates, probes_leave_episodes_unchanged
from taskcomplexity.tasks import contact


def test_probing_the_physics_steps_leaves_every_episode_bit_for_bit_unchanged():
    """The measurement's premise: saveState/restoreState and the re-set torque leave PyBullet's episodes as
    they are, so the rates are those of RWG's episodes (20 episodes, several fresh block contacts)."""
    assert probes_leave_episodes_unchanged()


@pytest.fixture(scope="module")
def measured():
    return measure_single_sweep_rates(policies=300, episodes=5, seed=0)


@pytest.mark.slow
@pytest.mark.parametrize(("kind", "constant"), [("fresh", contact.P_SINGLE_FRESH),
                                                 ("continuing", contact.P_SINGLE_CONTINUING)])
def test_each_one_sweep_rate_is_within_3_standard_errors_of_pybullets(measured, kind, constant):
    rate = getattr(measured, kind)
    assert rate.informative > 1000  # enough steps for the binomial error to mean something
    # 3 binomial standard errors: a constant that agrees fails this 0.3 % of the time
    assert abs(constant - rate.rate) <= 3 * rate.standard_error, (
        f"{kind}: constant {constant}, measured {rate.rate:.4f} ± {rate.standard_error:.4f} "
        f"({rate.single} of {rate.informative} informative steps)")
