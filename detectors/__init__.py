"""Detectors: sources of per-frame 2D keypoints (precomputed files, ONNX models) and tracking."""
