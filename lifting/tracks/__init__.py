"""Lifting tracks: each person's root path, windows sampled in batches and stitched, streamed into arrays."""
