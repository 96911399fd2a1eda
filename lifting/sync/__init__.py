"""Putting a take's views on one clock: time offsets from the keypoints' motion, and the user's choice."""
