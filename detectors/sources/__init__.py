"""Where 2D keypoints come from: our keypoint files, OpenPose, MMPose/COCO and the minimal JSON schema read into tracks,
the reader picked by what a source is, the checks every reader makes, a known root path, and video frames."""
