"""Lifting: the shared base (skeleton, cameras, floor, settings, errors) and one sub-package per job: the prior,
the guided sampler, tracks, sync, what happens after sampling, checks, calibration, mocap files, offline work."""
