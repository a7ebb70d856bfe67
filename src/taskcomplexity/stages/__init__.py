"""The stages of a study: one declared record per stage, its cache keys, the content-addressed cache and its runs.

Modules
-------
actor_stages
    Running a stage built on SAC's trained actors (occupancy, learning path) over a study's tasks.
ahead
    The per-task stages that read only a task's returns, computed ahead in a background process.
cache
    The content-addressed cache: atomic writes, manifests, corrupt artefacts detected and recomputed.
declared
    The stages a study runs before its verdict, one record each, found and ordered.
diagnostics_stage
    The diagnostics stage: how much of a task's PIC is estimator bias.
keys
    Cache keys: a hash of the stage's name, numerics version, canonical settings and input keys.
learning_path_stage
    The learning-path stage: PIC and POIC around each snapshot of a task's SAC actor.
metrics_stage
    The metrics stage: an RWG artefact and the estimator settings → metrics, bootstrap and batch tables.
occupancy_stage
    The occupancy stage: a task's random policies and its trained SAC actor → occupancy distances.
primitives_stage
    The primitives stage: PIC and POIC of every study task under the movement-primitive family.
resources
    What a run needs of this machine, refused up front when it is more than the machine has.
rwg_stage
    The RWG stage: (task, network, prior, N, M, seed, backend) → ``returns.parquet``.
sac_stage
    The SAC stage: (task, SAC settings, variant, seed group) → ``curves.parquet``.
stage
    What a stage is: one record naming its settings, config group, inputs, files, numerics and verdict role.
stage_log
    What a stage says: one DEBUG line per task (the run log), one INFO summary (the console).
task_artefacts
    Every task's RWG and metrics artefacts, pulled in study order.
verdict_stage
    The verdict stage: a study's metric artefacts and its relations → the verdict.
"""
