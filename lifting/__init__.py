"""Lifting: skeleton, cameras, motion prior, guided diffusion sampler, metrics."""
