"""Import a platypose BVH in Blender headless and compare the armature's joints with the npz median.

Run with a Python that has Blender as a module (``pip install bpy`` in a separate venv: the bpy
wheel pins its own numpy), e.g.::

    python tools/bvh_in_blender.py OUT/clip/clip_p0.bvh OUT/clip/clip.npz 0

Prints Blender's version, the scene's frame rate and range after the import (with the documented
settings: Scale 0.01, Forward -Z, Up Y, Update Scene FPS), and the distance of every joint of the
armature to the npz median of that person index (mean, max), and in how many frames the head is
below the neck, and the largest angle between the head bone and the npz neck-to-head line; and the
largest frame-to-frame turn of any pose bone's own rotation (``matrix_basis``) as Blender plays it.
"""

import sys

import bpy
import numpy as np

bvh, npz, person = sys.argv[1], sys.argv[2], int(sys.argv[3])
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_anim.bvh(
    filepath=bvh,
    global_scale=0.01,
    update_scene_fps=True,
    update_scene_duration=True,
    axis_forward="-Z",
    axis_up="Y",
    rotate_mode="NATIVE",
)
scene = bpy.context.scene
arm = [o for o in scene.objects if o.type == "ARMATURE"][0]
fps = scene.render.fps / scene.render.fps_base
print(
    "blender",
    bpy.app.version_string,
    "fps",
    fps,
    "frames",
    scene.frame_start,
    scene.frame_end,
    "bones",
    len(arm.data.bones),
)
with np.load(npz, allow_pickle=False) as f:
    med = f["median"][person].astype(np.float64)
    names = [str(n) for n in f["joint_names"]]
err, head_angles, basis = [], [], []
head_below = npz_below = 0
neck, head = names.index("neck"), names.index("head")
for t in range(scene.frame_start, min(scene.frame_end + 1, scene.frame_start + len(med))):
    scene.frame_set(t)
    basis.append([np.array(b.matrix_basis.to_3x3()) for b in arm.pose.bones])
    pos = np.array([list(arm.matrix_world @ arm.pose.bones[n].head) for n in names])
    bone = arm.pose.bones["head"]
    head_dir = np.array(list(arm.matrix_world @ bone.tail)) - pos[head]  # the head bone, towards its end site
    m = med[t - scene.frame_start]
    if np.isfinite(m).all():
        err.append(np.linalg.norm(pos - m, axis=1))
        head_below += pos[head, 2] < pos[neck, 2]
        npz_below += m[head, 2] < m[neck, 2]
        seen = m[head] - m[neck]
        cos = head_dir @ seen / np.linalg.norm(head_dir) / np.linalg.norm(seen)
        head_angles.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
err = np.array(err)
print(
    f"joints vs npz: mean {1000 * err.mean():.1f} mm, max {1000 * err.max():.1f} mm; head below neck in {head_below} "
    f"frames (npz: {npz_below}); head bone vs the npz neck-to-head line: max {max(head_angles):.2f} deg"
)
basis = np.array(basis)
rel = np.swapaxes(basis[:-1], -1, -2) @ basis[1:]
steps = np.degrees(np.arccos(np.clip((np.trace(rel, axis1=-2, axis2=-1) - 1) / 2, -1, 1)))
t, b = np.unravel_index(steps.argmax(), steps.shape)
print(
    f"pose bones: largest frame-to-frame turn {steps[t, b]:.1f} deg ({arm.pose.bones[b].name}, Blender frames "
    f"{t + scene.frame_start}-{t + 1 + scene.frame_start}), turns over 45 deg: {int((steps > 45).sum())}"
)
