"""URDF files: what we ship is what the arm specs write, and PyBullet reads the published physics."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pybullet
import pytest
from pybullet_utils.bullet_client import BulletClient

from taskcomplexity.tasks.dynamics import ArmDynamics
from taskcomplexity.tasks.spec import LinkSpec, arm_presets
from taskcomplexity.tasks.urdf import PACKAGED, arm_urdf, read_arm_urdf, urdf_path


@pytest.fixture(scope="module")
def bullet():
    client = BulletClient(connection_mode=pybullet.DIRECT)
    yield client
    client.disconnect()


@pytest.mark.parametrize("name", sorted(PACKAGED))
def test_packaged_urdf_is_what_the_spec_writes(name):
    packaged = resources.files("taskcomplexity.tasks") / "urdf" / f"{name}.urdf"
    assert packaged.read_text() == arm_urdf(arm_presets()[name])
    assert urdf_path(arm_presets()[name]) == type(urdf_path(arm_presets()[name]))(str(packaged))


@pytest.mark.parametrize(
    ("name", "masses", "coms"),
    [
        ("one_link_1m0", [6.75], [0.50]),
        ("one_link_1m65", [11.475], [0.80]),
        ("two_link", [5.0625, 6.75], [0.0, 0.0]),
    ],
)
def test_pybullet_keeps_urdf_masses_and_centres_of_mass(bullet, name, masses, coms):
    body = bullet.loadURDF(str(urdf_path(arm_presets()[name])), useFixedBase=True)
    for j, (mass, com) in enumerate(zip(masses, coms, strict=True)):
        info = bullet.getDynamicsInfo(body, j)
        assert info[0] == pytest.approx(mass, abs=1e-12)
        assert info[3][0] == pytest.approx(com, abs=1e-12)


@pytest.mark.parametrize("name", sorted(arm_presets()))
def test_our_inertia_derivation_equals_pybullets(bullet, name):
    # PyBullet recomputes the inertia from the collision box (with a compound margin when offset).
    body = bullet.loadURDF(str(urdf_path(arm_presets()[name])), useFixedBase=True)
    ours = [link.inertia_zz for link in read_arm_urdf(urdf_path(arm_presets()[name]))]
    theirs = [bullet.getDynamicsInfo(body, j)[2][2] for j in range(bullet.getNumJoints(body))]
    np.testing.assert_allclose(ours, theirs, rtol=1e-12)


@pytest.mark.parametrize(("name", "pivot_inertia"), [("one_link_1m0", 2.25377325), ("one_link_1m65", 10.109953)])
def test_one_link_pivot_inertia_matches_environments_md(name, pivot_inertia):
    link = read_arm_urdf(urdf_path(arm_presets()[name]))[0]
    assert link.inertia_zz + link.mass * link.com**2 == pytest.approx(pivot_inertia, abs=1e-6)


def test_two_link_mass_matrix_is_the_constant_of_environments_md_at_every_configuration(bullet):
    body = bullet.loadURDF(str(urdf_path(arm_presets()["two_link"])), useFixedBase=True)
    expected = np.array([[4.11349, 0.56627], [0.56627, 0.56627]])  # as printed in environments.md (5 decimals)
    ours = ArmDynamics(read_arm_urdf(urdf_path(arm_presets()["two_link"])))
    for q in [(0.0, 0.0), (1.0, 2.0), (3.0, -1.0), (5.5, 0.3)]:
        theirs = np.array(bullet.calculateMassMatrix(body, list(q)))
        np.testing.assert_allclose(theirs, expected, atol=5e-6)  # the spec rounds to 1e-5
        np.testing.assert_allclose(ours.mass_matrix(q[1]), theirs, atol=1e-12)


def test_a_configured_arm_gets_its_own_urdf_file(tmp_path, monkeypatch):
    monkeypatch.setenv("TASKCOMPLEXITY_URDF_CACHE", str(tmp_path))
    import dataclasses

    arm = dataclasses.replace(arm_presets()["one_link_1m0"], name="one_link_1m2", links=(LinkSpec(1.2, 8.4, 0.6),))
    path = urdf_path(arm)
    assert path.parent == tmp_path
    assert read_arm_urdf(path)[0].mass == 8.4
