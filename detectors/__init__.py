"""Detectors: 2D keypoints in. ``sources/`` reads keypoint files and video frames, ``models/`` runs ONNX pose models,
``tracking/`` keeps persistent IDs, ``persons/`` matches them across views and puts a take on one clock; one view is
read by ``view_reader`` (a video detected by ``video_detection``, cached by ``cache``)."""
