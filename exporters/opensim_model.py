"""An OpenSim model of our 17 joints, built here with OpenSim's API, and its scaling and IK set-ups.

The model (``platypose17``) has one body per segment our joints define: pelvis, torso
(spine to shoulders), head, and per side thigh, shank, upper arm and forearm. Each
joint of ours is a joint of the model, and each marker sits on a joint centre, named
as our TRC writes it (:data:`exporters.markers.MARKER_NAMES`): ``Neck`` is where our
neck joint is (the head's pivot), not the base of the neck. Joints: the pelvis is free
(6 coordinates), lumbar, neck, hips and shoulders are ball joints (3 each), knees and
elbows pins (flexion positive, held by IK within -20 to 170 degrees). Axes are OpenSim's (X forward, Y up, Z right), lengths
the median adult of our lifts, masses a 70 kg adult's segment fractions.

Scaling scales each body by the distances of its markers (:data:`MEASUREMENTS`), as
measured over the trial; IK then weights every marker alike. Everything here needs the
``opensim`` package, imported by the caller (``platypose[opensim]``).
"""

from __future__ import annotations

import math
from typing import Any

# body -> (parent body, joint name, joint kind, joint location in the parent (m), mass fraction, length (m))
_BODIES: dict[str, tuple[str, str, str, tuple[float, float, float], float, float]] = {
    "pelvis": ("ground", "ground_pelvis", "free", (0.0, 0.0, 0.0), 0.142, 0.2),
    "torso": ("pelvis", "lumbar", "ball", (0.0, 0.25, 0.0), 0.355, 0.31),
    "head": ("torso", "neck", "ball", (0.0, 0.31, 0.0), 0.081, 0.11),
    "femur_r": ("pelvis", "hip_r", "ball", (0.0, 0.0, 0.105), 0.1, 0.41),
    "tibia_r": ("femur_r", "knee_r", "knee", (0.0, -0.41, 0.0), 0.0465, 0.4),
    "femur_l": ("pelvis", "hip_l", "ball", (0.0, 0.0, -0.105), 0.1, 0.41),
    "tibia_l": ("femur_l", "knee_l", "knee", (0.0, -0.41, 0.0), 0.0465, 0.4),
    "humerus_r": ("torso", "shoulder_r", "ball", (0.0, 0.245, 0.17), 0.028, 0.28),
    "forearm_r": ("humerus_r", "elbow_r", "elbow", (0.0, -0.28, 0.0), 0.022, 0.25),
    "humerus_l": ("torso", "shoulder_l", "ball", (0.0, 0.245, -0.17), 0.028, 0.28),
    "forearm_l": ("humerus_l", "elbow_l", "elbow", (0.0, -0.28, 0.0), 0.022, 0.25),
}
# marker -> (body, location in the body (m)): every marker on a joint centre.
MARKERS: dict[str, tuple[str, tuple[float, float, float]]] = {
    "Hip": ("pelvis", (0.0, 0.0, 0.0)),
    "RHip": ("femur_r", (0.0, 0.0, 0.0)),
    "RKnee": ("tibia_r", (0.0, 0.0, 0.0)),
    "RAnkle": ("tibia_r", (0.0, -0.4, 0.0)),
    "LHip": ("femur_l", (0.0, 0.0, 0.0)),
    "LKnee": ("tibia_l", (0.0, 0.0, 0.0)),
    "LAnkle": ("tibia_l", (0.0, -0.4, 0.0)),
    "Spine": ("torso", (0.0, 0.0, 0.0)),
    "Thorax": ("torso", (0.0, 0.245, 0.0)),
    "Neck": ("head", (0.0, 0.0, 0.0)),
    "Head": ("head", (0.0, 0.11, 0.0)),
    "LShoulder": ("humerus_l", (0.0, 0.0, 0.0)),
    "LElbow": ("forearm_l", (0.0, 0.0, 0.0)),
    "LWrist": ("forearm_l", (0.0, -0.25, 0.0)),
    "RShoulder": ("humerus_r", (0.0, 0.0, 0.0)),
    "RElbow": ("forearm_r", (0.0, 0.0, 0.0)),
    "RWrist": ("forearm_r", (0.0, -0.25, 0.0)),
}
# body -> marker pairs whose distance scales it (uniformly): the model's over the trial's average.
MEASUREMENTS: dict[str, tuple[tuple[str, str], ...]] = {
    "pelvis": (("RHip", "LHip"), ("Hip", "Spine")),
    "torso": (("Spine", "Thorax"), ("RShoulder", "LShoulder")),
    "head": (("Neck", "Head"),),
    "femur_r": (("RHip", "RKnee"),),
    "tibia_r": (("RKnee", "RAnkle"),),
    "femur_l": (("LHip", "LKnee"),),
    "tibia_l": (("LKnee", "LAnkle"),),
    "humerus_r": (("RShoulder", "RElbow"),),
    "forearm_r": (("RElbow", "RWrist"),),
    "humerus_l": (("LShoulder", "LElbow"),),
    "forearm_l": (("LElbow", "LWrist"),),
}
MASS_KG = 70.0
# The hinges' coordinates, in lifting.anatomy.hinges.HINGE_NAMES order, and their range (degrees, IK holds them inside).
HINGE_COORDINATES = ("knee_r_flexion", "knee_l_flexion", "elbow_r_flexion", "elbow_l_flexion")
HINGE_RANGE_DEG = (-20.0, 170.0)
# Weight of a hinge's hint per squared radian against 1 per squared metre of marker error: 20 degrees off the hint
# cost as much as 6 cm of one marker's error, so the markers decide the pose and the hint the branch.
HINT_WEIGHT = 0.03
_BALL_AXES = (("_flexion", (0.0, 0.0, 1.0)), ("_adduction", (1.0, 0.0, 0.0)), ("_rotation", (0.0, 1.0, 0.0)))


def _vec(osim: Any, xyz: tuple[float, float, float]) -> Any:
    return osim.Vec3(*xyz)


def _joint(osim: Any, name: str, kind: str, parent: Any, location: tuple, child: Any) -> Any:
    """A joint of ``kind`` (free, ball, knee, elbow) at ``location`` in ``parent``, at the origin of ``child``.

    Ball joints turn about Z (flexion), X, Y in that order (a CustomJoint); pins about Z, the knee's frame
    turned half a turn about Y so that flexion (the shank going back) is positive, as the elbow's.
    """
    zero = osim.Vec3(0.0)
    if kind == "free":
        joint = osim.FreeJoint(name, parent, zero, zero, child, zero, zero)
        for k, coordinate in enumerate(("list", "rotation", "tilt", "tx", "ty", "tz")):
            joint.upd_coordinates(k).setName(f"pelvis_{coordinate}")
        return joint
    if kind in ("knee", "elbow"):
        turn = osim.Vec3(0.0, math.pi if kind == "knee" else 0.0, 0.0)
        joint = osim.PinJoint(name, parent, _vec(osim, location), turn, child, zero, turn)
        joint.upd_coordinates(0).setName(f"{name}_flexion")
        joint.upd_coordinates(0).setRangeMin(math.radians(HINGE_RANGE_DEG[0]))
        joint.upd_coordinates(0).setRangeMax(math.radians(HINGE_RANGE_DEG[1]))
        joint.upd_coordinates(0).set_clamped(True)  # IK keeps a hinge within -20 to 170 degrees
        return joint
    transform = osim.SpatialTransform()
    for k, (suffix, axis) in enumerate(_BALL_AXES):
        names = osim.ArrayStr()
        names.append(f"{name}{suffix}")
        rotation = transform.updTransformAxis(k)
        rotation.setCoordinateNames(names)
        rotation.setAxis(_vec(osim, axis))
        rotation.set_function(osim.LinearFunction())
    return osim.CustomJoint(name, parent, _vec(osim, location), zero, child, zero, zero, transform)


def build_model(osim: Any) -> Any:
    """The generic ``platypose17`` model (an ``opensim.Model``), finalised."""
    model = osim.Model()
    model.setName("platypose17")
    model.setGravity(osim.Vec3(0.0, -9.80665, 0.0))
    bodies = {"ground": model.getGround()}
    for name, (parent, joint, kind, location, fraction, length) in _BODIES.items():
        mass = fraction * MASS_KG
        down = -0.5 * length if name != "torso" and name != "head" else 0.5 * length
        inertia = mass * length**2 / 12.0
        body = osim.Body(name, mass, osim.Vec3(0.0, down, 0.0), osim.Inertia(inertia, inertia / 10, inertia))
        model.addBody(body)
        model.addJoint(_joint(osim, joint, kind, bodies[parent], location, body))
        bodies[name] = body
    for marker, (body, location) in MARKERS.items():
        model.addMarker(osim.Marker(marker, bodies[body], _vec(osim, location)))
    model.finalizeConnections()
    return model


def scale_tool(osim: Any, model_file: str, trc_file: str, times: tuple[float, float], output_file: str) -> Any:
    """An ``opensim.ScaleTool`` scaling ``model_file`` by :data:`MEASUREMENTS` on ``trc_file`` over ``times``
    (s) into ``output_file``; the markers stay on the joint centres (no marker placement)."""
    tool = osim.ScaleTool()
    tool.setName("platypose17_scale")
    tool.setSubjectMass(MASS_KG)
    tool.getGenericModelMaker().setModelFileName(model_file)
    scaler = tool.getModelScaler()
    scaler.setApply(True)
    order = osim.ArrayStr()
    order.append("measurements")
    scaler.setScalingOrder(order)
    for body, pairs in MEASUREMENTS.items():
        measurement = osim.Measurement()
        measurement.setName(body)
        for first, second in pairs:
            measurement.getMarkerPairSet().cloneAndAppend(osim.MarkerPair(first, second))
        scale = osim.BodyScale()
        scale.setName(body)
        axes = osim.ArrayStr()
        for axis in "XYZ":
            axes.append(axis)
        scale.setAxisNames(axes)
        measurement.getBodyScaleSet().cloneAndAppend(scale)
        scaler.addMeasurement(measurement)
    scaler.setMarkerFileName(trc_file)
    span = osim.ArrayDouble()
    span.append(times[0])
    span.append(times[1])
    scaler.setTimeRange(span)
    scaler.setPreserveMassDist(True)
    scaler.setOutputModelFileName(output_file)
    tool.getMarkerPlacer().setApply(False)
    return tool


def ik_tool(
    osim: Any, trc_file: str, times: tuple[float, float], output_file: str, hint_file: str | None = None
) -> Any:
    """An ``opensim.InverseKinematicsTool`` fitting every marker of :data:`MARKERS` (weight 1) of ``trc_file``
    over ``times`` (s), writing the coordinates (degrees) to ``output_file``; set its model before running.

    ``hint_file`` (a storage of the :data:`HINGE_COORDINATES`, degrees) holds each hinge near the flexion our
    joints give it with weight ``HINT_WEIGHT``: a knee or an elbow reaches a pose by two branches (flexion, and
    the opposite flexion with the bone above turned half a turn), and IK, which starts each frame from the one
    before, otherwise stays on the branch it started on, pinned at the hinge's limit."""
    tool = osim.InverseKinematicsTool()
    tool.setName("platypose17_ik")
    tool.set_marker_file(trc_file)
    tool.set_time_range(0, times[0])
    tool.set_time_range(1, times[1])
    tool.set_output_motion_file(output_file)
    tool.set_report_errors(True)
    tasks = tool.getIKTaskSet()
    for marker in MARKERS:
        task = osim.IKMarkerTask()
        task.setName(marker)
        task.setApply(True)
        task.setWeight(1.0)
        tasks.cloneAndAppend(task)
    if hint_file is not None:
        tool.set_coordinate_file(hint_file)
        for coordinate in HINGE_COORDINATES:
            task = osim.IKCoordinateTask()
            task.setName(coordinate)
            task.setApply(True)
            task.setWeight(HINT_WEIGHT)
            task.setValueType(osim.IKCoordinateTask.FromFile)
            tasks.cloneAndAppend(task)
    return tool
