"""The policy families whose random members RWG runs: random MLPs (:mod:`.mlp`) and movement primitives
(:mod:`.primitives` over :mod:`.movement_primitives`); :mod:`.families` declares what a family is (its spec and
batch protocols), registers them by ``network.family`` and picks one from its config."""
