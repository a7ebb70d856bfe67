"""The policy families whose random members RWG runs: random MLPs (:mod:`.mlp`) and movement primitives
(:mod:`.primitives` over :mod:`.movement_primitives`); :mod:`.families` picks one from its config."""
