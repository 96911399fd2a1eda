"""ONNX pose models: their contracts (MoveNet, RTMO, YOLO-pose, top-down with a person detector), the session,
the image tensors and letterbox, box maths; the bundled weights (``*.onnx``) lie here as package data."""
