"""How each of our 17 joints is obtained from every other skeleton, written once.

A recipe maps each of our joint names to a weighted average of named source
points (weights sum to 1). 2D keypoint sets and 3D mocap skeletons use the same
machinery so that a joint means the same point in 2D and in 3D (see the joint
meanings in :mod:`lifting.skeleton`).

Confidence of a synthesised joint (one made from several source points) is
the minimum of the confidences of the points it is made from: a joint is only
as certain as its least certain ingredient.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from platypose.lifting.skeleton import JOINT_NAMES

Recipe = Mapping[str, Mapping[str, float]]


def _mid(a: str, b: str) -> dict[str, float]:
    return {a: 0.5, b: 0.5}


COCO17_NAMES: tuple[str, ...] = (
    "nose",
    "left_eye",
    "right_eye",
    "left_ear",
    "right_ear",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
)

# COCO-17 (MoveNet, YOLO-pose, RTMPose, MMPose body models) -> ours.
# head (centre of the head) is the ear midpoint; neck (base of the skull) lies
# 30% of the way from the head centre to the thorax, the ratio the mocap
# skeletons show (0.27-0.38), so 2D and 3D necks mean the same point.
COCO17_RECIPE: Recipe = {
    "pelvis": _mid("left_hip", "right_hip"),
    "right_hip": {"right_hip": 1.0},
    "right_knee": {"right_knee": 1.0},
    "right_ankle": {"right_ankle": 1.0},
    "left_hip": {"left_hip": 1.0},
    "left_knee": {"left_knee": 1.0},
    "left_ankle": {"left_ankle": 1.0},
    "spine": {"left_hip": 0.25, "right_hip": 0.25, "left_shoulder": 0.25, "right_shoulder": 0.25},
    "thorax": _mid("left_shoulder", "right_shoulder"),
    "neck": {"left_shoulder": 0.15, "right_shoulder": 0.15, "left_ear": 0.35, "right_ear": 0.35},
    "head": _mid("left_ear", "right_ear"),
    "left_shoulder": {"left_shoulder": 1.0},
    "left_elbow": {"left_elbow": 1.0},
    "left_wrist": {"left_wrist": 1.0},
    "right_shoulder": {"right_shoulder": 1.0},
    "right_elbow": {"right_elbow": 1.0},
    "right_wrist": {"right_wrist": 1.0},
}


def recipe_matrix(recipe: Recipe, source_names: Sequence[str]) -> np.ndarray:
    """Weight matrix ``W`` (17, S) with ``ours = W @ source``; raises KeyError on an unknown source name."""
    index = {name: i for i, name in enumerate(source_names)}
    weights = np.zeros((len(JOINT_NAMES), len(source_names)))
    for j, joint in enumerate(JOINT_NAMES):
        for source, w in recipe[joint].items():
            if source not in index:
                raise KeyError(f"recipe for {joint!r} needs source point {source!r}, which the skeleton lacks")
            weights[j, index[source]] = w
    return weights


def apply_recipe(points: np.ndarray, source_names: Sequence[str], recipe: Recipe) -> np.ndarray:
    """Map source points ``(..., S, D)`` onto our joints ``(..., 17, D)`` by weighted averages."""
    weights = recipe_matrix(recipe, source_names)
    return np.einsum("js,...sd->...jd", weights, points)


def apply_recipe_with_confidence(
    points: np.ndarray, confidence: np.ndarray, source_names: Sequence[str], recipe: Recipe
) -> tuple[np.ndarray, np.ndarray]:
    """Map 2D keypoints ``(..., S, 2)`` with confidences ``(..., S)`` onto ours.

    Returns points ``(..., 17, 2)`` and confidences ``(..., 17)``, each joint's
    confidence being the minimum over the source points it is made from.
    """
    weights = recipe_matrix(recipe, source_names)
    mapped = np.einsum("js,...sd->...jd", weights, points)
    used = weights > 0
    conf = np.stack([confidence[..., used[j]].min(axis=-1) for j in range(len(JOINT_NAMES))], axis=-1)
    return mapped, conf


# --- 2D keypoint layouts of detectors and OpenPose (section owned by detectors/) ---
# Each layout names its points with the COCO-17 names where they mean the same
# point, so the COCO-17 recipe applies unchanged; extra points (OpenPose's neck
# and mid-hip, feet, head top) are named but not used. The one exception is
# BODY_25B, which observes the base of the skull directly ("upper_neck").

_FEET: tuple[str, ...] = (
    "left_big_toe",
    "left_small_toe",
    "left_heel",
    "right_big_toe",
    "right_small_toe",
    "right_heel",
)

# OpenPose COCO-18 (and the first 18 points of BODY_25 before its mid-hip).
COCO18_NAMES: tuple[str, ...] = (
    "nose",
    "openpose_neck",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "right_hip",
    "right_knee",
    "right_ankle",
    "left_hip",
    "left_knee",
    "left_ankle",
    "right_eye",
    "left_eye",
    "right_ear",
    "left_ear",
)

# OpenPose BODY_25 (default OpenPose model).
BODY25_NAMES: tuple[str, ...] = (
    "nose",
    "openpose_neck",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "mid_hip",
    "right_hip",
    "right_knee",
    "right_ankle",
    "left_hip",
    "left_knee",
    "left_ankle",
    "right_eye",
    "left_eye",
    "right_ear",
    "left_ear",
) + _FEET

# OpenPose experimental BODY_25B: COCO-17 order, then upper neck, head top, feet.
BODY25B_NAMES: tuple[str, ...] = COCO17_NAMES + ("upper_neck", "head_top") + _FEET

# Halpe-26 (AlphaPose, RTMPose body7 Halpe models): COCO-17, head top, neck, mid-hip, feet.
HALPE26_NAMES: tuple[str, ...] = (
    COCO17_NAMES
    + ("head_top", "openpose_neck", "mid_hip")
    + (
        "left_big_toe",
        "right_big_toe",
        "left_small_toe",
        "right_small_toe",
        "left_heel",
        "right_heel",
    )
)

# COCO-WholeBody-133 (RTMW, DWPose): COCO-17, 6 foot points, 68 face points, 2 x 21 hand points.
WHOLEBODY133_NAMES: tuple[str, ...] = (
    COCO17_NAMES
    + ("left_big_toe", "left_small_toe", "left_heel", "right_big_toe", "right_small_toe", "right_heel")
    + tuple(f"face_{i}" for i in range(68))
    + tuple(f"left_hand_{i}" for i in range(21))
    + tuple(f"right_hand_{i}" for i in range(21))
)

# BODY_25B -> ours: as COCO-17, but neck is the observed upper neck (base of the skull).
BODY25B_RECIPE: Recipe = {**COCO17_RECIPE, "neck": {"upper_neck": 1.0}}

# Layout name -> (source point names, recipe), for every 2D keypoint set we read;
# "platypose17" is our own joints (identity), for files already in our layout.
KEYPOINT_LAYOUTS: dict[str, tuple[tuple[str, ...], Recipe]] = {
    "platypose17": (JOINT_NAMES, {name: {name: 1.0} for name in JOINT_NAMES}),
    "coco17": (COCO17_NAMES, COCO17_RECIPE),
    "coco18": (COCO18_NAMES, COCO17_RECIPE),
    "body25": (BODY25_NAMES, COCO17_RECIPE),
    "body25b": (BODY25B_NAMES, BODY25B_RECIPE),
    "halpe26": (HALPE26_NAMES, COCO17_RECIPE),
    "wholebody133": (WHOLEBODY133_NAMES, COCO17_RECIPE),
}


# --- 3D mocap skeletons of the motion importers (section owned by lifting/motion_io/) ---
# Every mocap skeleton names its 12 limb joint centres; the midline joints are
# derived from them once, here, for all skeletons:
#   pelvis = midpoint of the hips, thorax = midpoint of the shoulders,
#   spine = midpoint of pelvis and thorax, neck = the base of the skull (the
#   joint the head pivots on, a mocap "Head" joint), head = centre of the head.
# Where a skeleton has a head-top point (a BVH Head End Site, the end of the CMU
# "head" bone) the head centre is the midpoint of skull base and head top.
# Where it has none, the head centre is extrapolated past the skull base along
# the neck by HEAD_EXTRAPOLATION of the neck length (holosoma: 0.5 x 0.14 m = 7 cm).

LIMB_JOINTS: tuple[str, ...] = (
    "right_hip",
    "right_knee",
    "right_ankle",
    "left_hip",
    "left_knee",
    "left_ankle",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
)

HEAD_EXTRAPOLATION = 0.5


def head_between(skull_base: str, head_top: str) -> dict[str, float]:
    """Head centre as the midpoint of the skull base and the head top."""
    return _mid(skull_base, head_top)


def head_beyond(skull_base: str, neck_base: str) -> dict[str, float]:
    """Head centre extrapolated past the skull base along the neck (base -> skull) by HEAD_EXTRAPOLATION."""
    return {skull_base: 1.0 + HEAD_EXTRAPOLATION, neck_base: -HEAD_EXTRAPOLATION}


def mocap_recipe(limbs: Mapping[str, str], neck: Mapping[str, float], head: Mapping[str, float]) -> Recipe:
    """Recipe from a mocap skeleton: ``limbs`` maps our 12 limb joints to source names; neck and head are weights."""
    missing = [j for j in LIMB_JOINTS if j not in limbs]
    if missing:
        raise KeyError(f"mocap name map lacks {missing}")
    recipe: dict[str, Mapping[str, float]] = {j: {limbs[j]: 1.0} for j in LIMB_JOINTS}
    hips = _mid(limbs["left_hip"], limbs["right_hip"])
    shoulders = _mid(limbs["left_shoulder"], limbs["right_shoulder"])
    recipe["pelvis"] = hips
    recipe["thorax"] = shoulders
    recipe["spine"] = {k: 0.5 * w for k, w in (*hips.items(), *shoulders.items())}
    recipe["neck"] = dict(neck)
    recipe["head"] = dict(head)
    return recipe


# holosoma-retargeting "mocap" layout (T, 53, 3): Vicon-style names, hands with fingers.
HOLOSOMA_MOCAP_NAMES: tuple[str, ...] = (
    ("Hips", "Spine", "Spine1", "Neck", "Head", "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand")
    + tuple(f"LeftHand{f}{i}" for f in ("Thumb", "Index", "Middle", "Ring", "Pinky") for i in (1, 2, 3))
    + ("RightShoulder", "RightArm", "RightForeArm", "RightHand")
    + tuple(f"RightHand{f}{i}" for f in ("Thumb", "Index", "Middle", "Ring", "Pinky") for i in (1, 2, 3))
    + ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase")
    + ("LeftFootMod", "RightFootMod")
)

# Limb names shared by Vicon/MotionBuilder/Mixamo/LaFAN style skeletons (holosoma, many BVH files).
MOTIONBUILDER_LIMBS: dict[str, str] = {
    "right_hip": "RightUpLeg",
    "right_knee": "RightLeg",
    "right_ankle": "RightFoot",
    "left_hip": "LeftUpLeg",
    "left_knee": "LeftLeg",
    "left_ankle": "LeftFoot",
    "left_shoulder": "LeftArm",
    "left_elbow": "LeftForeArm",
    "left_wrist": "LeftHand",
    "right_shoulder": "RightArm",
    "right_elbow": "RightForeArm",
    "right_wrist": "RightHand",
}

HOLOSOMA_MOCAP_RECIPE: Recipe = mocap_recipe(MOTIONBUILDER_LIMBS, {"Head": 1.0}, head_beyond("Head", "Neck"))

# CMU ASF/AMC: each bone's point is its END (lhipjoint ends at the hip joint centre,
# lfemur at the knee, ...); upperneck ends at the skull base, head at the head top.
CMU_ASF_LIMBS: dict[str, str] = {
    "right_hip": "rhipjoint",
    "right_knee": "rfemur",
    "right_ankle": "rtibia",
    "left_hip": "lhipjoint",
    "left_knee": "lfemur",
    "left_ankle": "ltibia",
    "left_shoulder": "lclavicle",
    "left_elbow": "lhumerus",
    "left_wrist": "lradius",
    "right_shoulder": "rclavicle",
    "right_elbow": "rhumerus",
    "right_wrist": "rradius",
}

CMU_ASF_RECIPE: Recipe = mocap_recipe(CMU_ASF_LIMBS, {"upperneck": 1.0}, head_between("upperneck", "head"))

# DeepMimic humanoid (pybullet humanoid.urdf): points are joint frames, plus
# "head_centre", the centre of the head sphere of the neck link. Its single
# neck joint sits just below shoulder height, no guide to the skull base, so the
# skull base is put SKULL_BASE_FRACTION of the way from the head centre to the
# thorax, as the other skeletons have it (holosoma 0.27, CMU 0.29, mocapbank 0.38).
SKULL_BASE_FRACTION = 0.3
DEEPMIMIC_RECIPE: Recipe = mocap_recipe(
    {j: j for j in LIMB_JOINTS},
    {
        "head_centre": 1.0 - SKULL_BASE_FRACTION,
        "left_shoulder": SKULL_BASE_FRACTION / 2,
        "right_shoulder": SKULL_BASE_FRACTION / 2,
    },
    {"head_centre": 1.0},
)


# BVH: known naming conventions as (limbs, skull-base joint, head centre), tried
# in order; the first whose names all exist in a file is used (a user name map,
# our 12 limb names plus "neck" -> the skull-base joint and optionally "head" ->
# a head-centre joint, overrides). The head centre is a joint's name or weights
# over joints (rigs whose head joint is the skull base and whose only points
# further up are the eyes: the centre is halfway from the skull base to the
# eyes' midpoint). Without one the head centre uses the skull-base joint's End
# Site when the file has one (head_between), else head_beyond with the joint's
# parent as the neck base.
def _between_eyes(skull_base: str, left_eye: str, right_eye: str) -> dict[str, float]:
    """Head centre halfway from the skull base to the midpoint of the eyes."""
    return {skull_base: 0.5, left_eye: 0.25, right_eye: 0.25}


def _rig_limbs(hip: str, knee: str, ankle: str, shoulder: str, elbow: str, wrist: str) -> dict[str, str]:
    """Our 12 limb joints from a rig's per-side templates (``{S}`` is the side's letter, R or L; ``{s}`` r or l)."""
    names = {"hip": hip, "knee": knee, "ankle": ankle, "shoulder": shoulder, "elbow": elbow, "wrist": wrist}
    return {
        f"{side}_{joint}": template.format(S=side[0].upper(), s=side[0])
        for side in ("right", "left")
        for joint, template in names.items()
    }


BVH_NAMING: dict[str, tuple[dict[str, str], str, str | Mapping[str, float] | None]] = {
    "platypose": ({j: j for j in LIMB_JOINTS}, "neck", "head"),  # our own exporter's BVH
    "motionbuilder": (MOTIONBUILDER_LIMBS, "Head", None),
    "mocapbank": (
        {
            "right_hip": "RightHip",
            "right_knee": "RightKnee",
            "right_ankle": "RightAnkle",
            "left_hip": "LeftHip",
            "left_knee": "LeftKnee",
            "left_ankle": "LeftAnkle",
            "left_shoulder": "LeftShoulder",
            "left_elbow": "LeftElbow",
            "left_wrist": "LeftWrist",
            "right_shoulder": "RightShoulder",
            "right_elbow": "RightElbow",
            "right_wrist": "RightWrist",
        },
        "Head",
        None,
    ),
    # Poser / DAZ rigs (CMU mocap as retargeted for Poser: hip abdomen chest neck head ...)
    "poser": (
        _rig_limbs("{s}Thigh", "{s}Shin", "{s}Foot", "{s}Shldr", "{s}ForeArm", "{s}Hand"),
        "head",
        _between_eyes("head", "leftEye", "rightEye"),
    ),
    # Reallusion Character Creator (iClone) rigs
    "character_creator": (
        _rig_limbs(
            "CC_Base_{S}_Thigh",
            "CC_Base_{S}_Calf",
            "CC_Base_{S}_Foot",
            "CC_Base_{S}_Upperarm",
            "CC_Base_{S}_Forearm",
            "CC_Base_{S}_Hand",
        ),
        "CC_Base_Head",
        _between_eyes("CC_Base_Head", "CC_Base_L_Eye", "CC_Base_R_Eye"),
    ),
    # Blender Rigify-style metarig exports (ReActIdle): no hand joint, the wrist is the forearm's End Site
    # ("_end", as the BVH reader names End Sites); "neck" sits at shoulder height and "face" at the skull
    # base, its End Site a centimetre away, so the head centre is extrapolated past "face" (head_beyond).
    "rigify": (
        _rig_limbs("thigh.{S}", "shin.{S}", "foot.{S}", "upper_arm.{S}", "forearm.{S}", "forearm.{S}_end"),
        "face",
        head_beyond("face", "neck"),
    ),
}

# Human3.6M 32-joint mocap (VideoPose3D data_3d_h36m.npz) -> ours: index of each
# of our joints among the 32. H36M's own definitions apply (its "neck/nose" and
# "head" points; its pelvis is the root joint, close to the hips' midpoint).
H36M32_TO_OURS: tuple[int, ...] = (0, 1, 2, 3, 6, 7, 8, 12, 13, 14, 15, 17, 18, 19, 25, 26, 27)


# C3D marker trials (clinical gait labs): for each joint, alternative weightings
# of named points, most direct first: joint centres exported by the lab's model
# (RHJC/RKJC/RAJC), then Vicon Plug-in Gait segment points (femur proximal end
# RFEP = hip centre, femur origin RFEO = knee centre, tibia origin RTIO = ankle
# centre), then midpoints of lateral/medial epicondyle and malleolus markers,
# then the bare Plug-in Gait full-body markers (below). The first alternative
# whose points a trial has is used; joints with none stay NaN and are reported
# as missing (no upper body in lower-body trials).
def _sides(template: tuple[dict[str, float], ...]) -> dict[str, tuple[dict[str, float], ...]]:
    """Right and left versions of a template: ``{s}`` is R/L, ``{o}`` the other side's letter, ``{side}`` Right/Left."""

    def side(s: str, o: str, full: str) -> tuple[dict[str, float], ...]:
        return tuple({k.format(s=s, o=o, side=full): w for k, w in alt.items()} for alt in template)

    return {"right": side("R", "L", "Right"), "left": side("L", "R", "Left")}


def _blend(*parts: tuple[float, Mapping[str, float]]) -> dict[str, float]:
    """Weighted sum of recipes, ``sum(a * recipe)``: e.g. the midpoint of two joints each made of markers."""
    out: dict[str, float] = {}
    for a, recipe in parts:
        for name, w in recipe.items():
            out[name] = out.get(name, 0.0) + a * w
    return out


# Plug-in Gait full-body markers alone (no model outputs, no medial markers):
# hip, knee and ankle centres as affine combinations of the skin markers, the
# weights fitted by least squares (both sides pooled) to the Plug-in Gait
# centres RFEP/RFEO/RTIO of the gaitalytics treadmill trial in
# data/motion/gait-c3d, where they are off by a median 19 / 11 / 11 mm (the
# bare lateral markers ASI / KNE / ANK: 116 / 59 / 45 mm).
PIG_HIP = {"{s}ASI": 0.822, "{o}ASI": -0.348, "{s}PSI": -0.646, "{o}PSI": 0.981, "{s}KNE": 0.191}
PIG_KNEE = {"{s}KNE": 1.097, "{s}ANK": -0.061, "{s}ASI": -0.304, "{o}ASI": 0.268}
PIG_ANKLE = {"{s}ANK": -0.051, "{s}TOE": 0.310, "{s}HEE": 0.668, "{s}KNE": 0.073}
# The upper body has no fitted reference: shoulder = the acromion marker SHO
# (4-6 cm above the joint centre), elbow = the lateral epicondyle marker ELB
# (about 3 cm lateral of it), wrist = midpoint of the two wrist-bar markers,
# head centre = mean of the four head markers, skull base SKULL_BASE_FRACTION
# of the way from the head centre to the thorax (as for DeepMimic).
PIG_SHOULDER = {"{s}SHO": 1.0}
PIG_ELBOW = {"{s}ELB": 1.0}
PIG_WRIST = _mid("{s}WRA", "{s}WRB")

_PIG_HIPS = _sides((PIG_HIP,))
_C3D_HIP = _sides(({"{s}HJC": 1.0}, {"{s}FEP": 1.0}, PIG_HIP))
_C3D_KNEE = _sides(
    (
        {"{s}KJC": 1.0},
        {"{s}FEO": 1.0},
        _mid("{s}LEK", "{s}MEK"),
        _mid("{side}_KneeExt", "{side}_KneeInt"),
        PIG_KNEE,
    )
)
_C3D_ANKLE = _sides(
    (
        {"{s}AJC": 1.0},
        {"{s}TIO": 1.0},
        _mid("{s}LM", "{s}MM"),
        _mid("{side}_AnkleExt", "{side}_AnkleInt"),
        PIG_ANKLE,
    )
)
_C3D_ARM = {
    part: _sides((recipe,)) for part, recipe in (("shoulder", PIG_SHOULDER), ("elbow", PIG_ELBOW), ("wrist", PIG_WRIST))
}
_PIG_PELVIS = _blend((0.5, _PIG_HIPS["left"][0]), (0.5, _PIG_HIPS["right"][0]))
_PIG_THORAX = _mid("LSHO", "RSHO")
_PIG_HEAD = {"LFHD": 0.25, "RFHD": 0.25, "LBHD": 0.25, "RBHD": 0.25}
_C3D_PELVIS = (_mid("LHJC", "RHJC"), _mid("LFEP", "RFEP"), _PIG_PELVIS)
C3D_MARKER_RECIPES: dict[str, tuple[dict[str, float], ...]] = {
    "pelvis": _C3D_PELVIS,
    **{f"{side}_hip": _C3D_HIP[side] for side in ("right", "left")},
    **{f"{side}_knee": _C3D_KNEE[side] for side in ("right", "left")},
    **{f"{side}_ankle": _C3D_ANKLE[side] for side in ("right", "left")},
    "spine": tuple(_blend((0.5, pelvis), (0.5, _PIG_THORAX)) for pelvis in _C3D_PELVIS),
    "thorax": (_PIG_THORAX,),
    "neck": (_blend((1.0 - SKULL_BASE_FRACTION, _PIG_HEAD), (SKULL_BASE_FRACTION, _PIG_THORAX)),),
    "head": (_PIG_HEAD,),
    **{f"{side}_{part}": _C3D_ARM[part][side] for part in ("shoulder", "elbow", "wrist") for side in ("left", "right")},
}
