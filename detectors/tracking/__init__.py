"""Tracking: persistent IDs from per-frame detections, ID switches and left/right label swaps undone, pose distances,
distances to reference keypoints."""
