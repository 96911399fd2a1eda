"""Exporters: npz (source of truth), CSV, BVH and rerun recordings."""
