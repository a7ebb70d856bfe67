"""Re-measure the obstacle contact model's one-sweep rates on PyBullet, beside the constants in use.

    python bench/calibrate_contacts.py                        # `make calibrate-contacts`: N = 300 × M = 5
    python bench/calibrate_contacts.py --policies 1000 --seed 1

``P_SINGLE_FRESH`` and ``P_SINGLE_CONTINUING`` (``taskcomplexity/tasks/contact.py``) are the rates at which
Bullet's solver stops after its first sweep at a physics step where the forearm touches the block,
for a new and a continuing contact. This script plays random-policy episodes of two_link_obstacle-dense
on PyBullet, finds out at every such step whether PyBullet stopped after one sweep (how:
``taskcomplexity/rwg/contact_calibration.py``), and prints each measured rate with its binomial
standard error beside the constant, their distance in standard errors, and how the rate splits on the
forearm–plane contact the mechanism needs. Rerun it after a PyBullet upgrade; a constant more than
about 3 standard errors off should be replaced by the measured rate (``tests/rwg/test_contact_calibration.py``
checks this under ``-m slow``).

Takes about 3 minutes at the default N = 300 × M = 5 (162 s on the 2-core development machine: 1 500
episodes, 1.5 million physics steps, 2 400 informative fresh steps), about 1 minute of it the plain
PyBullet episodes and the rest the probes of the 29 000 contact steps; the time grows linearly with
N × M and the standard errors shrink as 1/√(N × M).
"""

from __future__ import annotations

import argparse
import time

from taskcomplexity.rwg.contact_calibration import measure_single_sweep_rates
from taskcomplexity.tasks import contact


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--policies", type=int, default=300, help="random policies N (default 300)")
    parser.add_argument("--episodes", type=int, default=5, help="episodes per policy M (default 5)")
    parser.add_argument("--seed", type=int, default=0, help="RWG seed of the policies and initial states")
    args = parser.parse_args()
    import pybullet

    started = time.perf_counter()
    measured = measure_single_sweep_rates(policies=args.policies, episodes=args.episodes, seed=args.seed,
                                          progress=True)
    elapsed = time.perf_counter() - started
    print(f"two_link_obstacle-dense on PyBullet (API {pybullet.getAPIVersion()}), N = {args.policies} × "
          f"M = {args.episodes} (seed {args.seed}): {measured.episodes:,} episodes, "
          f"{measured.physics_steps:,} physics steps, {elapsed:.0f} s")
    print(f"\n{'':<21}{'constant':>10}{'measured':>10}{'± s.e.':>9}{'z':>7}{'one-sweep / informative':>26}"
          f"{'contact steps':>15}")
    for name, constant, rate in (("P_SINGLE_FRESH", contact.P_SINGLE_FRESH, measured.fresh),
                                 ("P_SINGLE_CONTINUING", contact.P_SINGLE_CONTINUING, measured.continuing)):
        z = (constant - rate.rate) / rate.standard_error
        print(f"{name:<21}{constant:>10.3f}{rate.rate:>10.3f}{rate.standard_error:>9.3f}{z:>+7.1f}"
              f"{f'{rate.single:,} / {rate.informative:,}':>26}{rate.steps:>15,}")
    print("z: (constant − measured) / s.e.; informative: one sweep and convergence differ at that step")
    print("\nsplit on the forearm–plane contact (the mechanism: one sweep only with the plane in the solve)")
    for kind, rate in (("fresh", measured.fresh), ("continuing", measured.continuing)):
        on_plane = rate.single_on_plane / rate.plane if rate.plane else float("nan")
        off = rate.informative - rate.plane
        off_plane = (rate.single - rate.single_on_plane) / off if off else float("nan")
        print(f"  {kind:<11} plane contact at {rate.plane / rate.informative:6.1%} of informative steps; one sweep "
              f"at {on_plane:6.1%} of those, {off_plane:6.1%} of the others")


if __name__ == "__main__":
    main()
