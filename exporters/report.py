"""The report picture of one input (``<name>_report.png``): per person, what a coach or clinician looks at first.

Under the title, where the lift estimated its camera (no calibration), each of its quantities with its spread and
source (:func:`platypose.exporters.horizon.camera_caption`); the person pictures then show its horizon. One row per
person: leg angles and arm/trunk angles over time (the median
motion's line and the hypotheses' 5-95 % band), the pelvis path seen from
above with every camera, and both ankle heights above the lift's floor (``meta["floor"]``: the calibration's,
given or estimated), or above the lowest ankle of the clip where the lift had none. Drawn with matplotlib's Agg
backend (no display needed).
"""

from __future__ import annotations

from pathlib import Path
from textwrap import fill, shorten

import numpy as np

from platypose.exporters.angles import ANGLE_NAMES
from platypose.exporters.frames import frame_chunks
from platypose.exporters.horizon import camera_caption, horizon_curve, horizon_place, in_thumbnail
from platypose.exporters.result import LiftResult
from platypose.lifting.files.atomic import atomic_path
from platypose.lifting.skeleton import JOINT_INDEX

LEG_ANGLES = ("right_hip_flexion", "left_hip_flexion", "right_knee_flexion", "left_knee_flexion")
UPPER_ANGLES = ("trunk_flexion", "right_shoulder_elevation", "left_shoulder_elevation", "right_elbow_flexion")
_COLOURS = ("tab:red", "tab:blue", "tab:orange", "tab:cyan")
MAX_ROWS = 8  # persons drawn (the longest present first)
WHO_CHARS = 24  # characters per line of the caption under a thumbnail (its column is narrow)
CAPTION_CHARS = 200  # characters per line of the estimated camera's caption under the title
FLAG_CHARS = (64, 256)  # a row's flag text: characters per line, in all (longer is cut with "...")


def _camera_centres(result: LiftResult) -> np.ndarray:
    """World positions (C, 3) of the cameras: ``-R^T t``."""
    return np.stack([-np.asarray(c.R).T @ np.asarray(c.t) for c in result.cameras])


def _track(result: LiftResult, p: int, joint: str) -> np.ndarray:
    """One joint's median path (T, 3) of person ``p``, NaN where absent."""
    j = JOINT_INDEX[joint]
    return np.concatenate([np.asarray(result.median[p, t, j], np.float64) for t in frame_chunks(result.num_frames)])


def ankle_heights(ankles: np.ndarray, floor: dict | None) -> tuple[np.ndarray, str]:
    """Heights (m) of ankle paths ``(..., 3)`` above ``floor`` (a ``meta["floor"]`` entry: ``normal``, ``offset_m``,
    ``source``), or above their own lowest point without one, and the axis label that says which."""
    ankles = np.asarray(ankles, np.float64)
    if floor:
        return ankles @ np.asarray(floor["normal"], np.float64) + float(floor["offset_m"]), (
            f"cm above the floor ({floor['source']})"
        )
    return ankles[..., 2] - np.nanmin(ankles[..., 2]), "cm above the lowest ankle"


def _flag_text(result: LiftResult, p: int) -> str:
    """What the lift flagged for person ``p`` (``meta["plausibility"]``'s ``flag_text``), or empty."""
    reports = (result.meta or {}).get("plausibility") or []
    report = reports[p] if p < len(reports) and isinstance(reports[p], dict) else {}
    return (report.get("flag_text") or ", ".join(report.get("flags", []))) if report.get("flags") else ""


def _draw_who(ax, result: LiftResult, p: int, good, picture) -> None:
    """Person ``p``'s thumbnail (or a blank) titled with their id, camera, frame and image box."""
    ax.set_axis_off()
    if picture is not None:
        ax.imshow(picture)
    lines = [f"person {int(result.track_ids[p])}"]
    if good is not None:
        x1, y1, x2, y2 = good.box
        camera = result.cameras[good.camera].name
        lines += [f"{camera} frame {good.frame}", f"box {x1:.0f},{y1:.0f}-{x2:.0f},{y2:.0f} px"]
        lines += [] if picture is not None else [f"(no thumbnail: no video of {camera} given)"]
        if picture is not None and (result.meta or {}).get("camera"):
            seen = result.cameras[good.camera]
            curve = horizon_curve(seen)
            place = horizon_place(
                None if curve is None else in_thumbnail(curve, good.box, picture.shape), picture.shape
            )
            lines += [] if place is None else [f"(the horizon is {place} the picture)"]
    ax.set_title("\n".join(fill(line, WHO_CHARS) for line in lines), fontsize=8)  # within the column's width


def _row_title(ax, title: str, flagged: str) -> None:
    """A row's first title, with the lift's flags (red, wrapped, cut to ``FLAG_CHARS``) below it in the same text,
    so the layout makes room for all of it and nothing is drawn over it."""
    if not flagged:
        ax.set_title(title, fontsize=10)
        return
    lines = fill(shorten(f"flagged: {flagged}", FLAG_CHARS[1], placeholder=" ..."), FLAG_CHARS[0])
    ax.set_title(f"{title}\n{lines}", fontsize=9, color="tab:red")


def _plot_angles(ax, times: np.ndarray, series: np.ndarray, names: tuple[str, ...]) -> None:
    """Median-motion lines and 5-95 % bands of ``names`` from a person's series (T, A, 4)."""
    for name, colour in zip(names, _COLOURS):
        a = ANGLE_NAMES.index(name)
        ax.fill_between(times, series[:, a, 1], series[:, a, 3], color=colour, alpha=0.18, linewidth=0)
        ax.plot(times, series[:, a, 0], color=colour, linewidth=1.2, label=name.replace("_", " "))
    ax.set_xlabel("time (s)")
    ax.set_ylabel("degrees")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")


def _shade_prior(ax, times: np.ndarray, prior: np.ndarray) -> None:
    """Grey spans over the frames ``prior`` (T,) where the person was unseen and the lift filled by the prior."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], prior.astype(np.int8), [0]])))
    for k, (first, stop) in enumerate(zip(edges[::2], edges[1::2])):
        label = "unseen: filled by the prior" if k == 0 else None
        ax.axvspan(times[first], times[stop - 1], color="0.5", alpha=0.2, linewidth=0, label=label)


def write_report(
    result: LiftResult,
    series: dict[int, np.ndarray],
    name: str,
    path: Path | str,
    who: tuple[dict, dict] = ({}, {}),
) -> Path:
    """Draw the report of ``result`` with its angle ``series`` (per person index, (T, A, 4)) to ``path`` atomically.

    ``who``: per person index their good frame and thumbnail (:mod:`exporters.person_pictures`), drawn first in
    their row with the camera, frame and image box, so a reader knows who the row is about."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    path = Path(path)
    longest = sorted(series, key=lambda p: -np.isfinite(series[p][:, 0, 0]).sum())[:MAX_ROWS]
    persons = sorted(longest, key=lambda p: int(result.track_ids[p]))  # rows in id order
    rows = max(len(persons), 1)
    fig = Figure(figsize=(18, 3.6 * rows + 0.8), dpi=100, layout="constrained")
    shown = int(bool(who[0]))  # a first column of who is who, when some person has a good frame
    grid = fig.subplots(rows, 4 + shown, squeeze=False, width_ratios=[1.2] * shown + [3, 3, 2, 3])
    axes = grid[:, shown:]
    times = result.frame_times
    cams = _camera_centres(result)
    prior = result.present() & ~result.seen()
    title = f"{name}: {result.num_persons} person(s), {result.num_hypotheses} hypotheses, "
    title += f"{result.num_frames} frames at {result.fps:g} fps, {len(result.cameras)} camera(s)"
    caption = camera_caption(result.meta or {})
    if caption and shown:
        caption[0] = f"camera estimated without a calibration (horizon: the magenta line in the pictures): {caption[0]}"
    elif caption:
        caption[0] = f"camera estimated without a calibration: {caption[0]}"
    fig.suptitle(
        title + "  (lines: median motion; bands: 5-95 % of the hypotheses; angles unwrapped over time, shoulders after"
        " ISB: elevation from hanging, docs/outputs.md)"
        + "".join(f"\n{fill(line, CAPTION_CHARS)}" for line in caption),
        fontsize=11,
    )
    for row, p in enumerate(persons):
        track = int(result.track_ids[p])
        s = series[p]
        if shown:
            _draw_who(grid[row, 0], result, p, *(part.get(p) for part in who))
        for ax in axes[row, [0, 1, 3]]:
            _shade_prior(ax, times, prior[p])
        _plot_angles(axes[row, 0], times, s, LEG_ANGLES)
        _row_title(axes[row, 0], f"person {track}: hips and knees", _flag_text(result, p))
        _plot_angles(axes[row, 1], times, s, UPPER_ANGLES)
        axes[row, 1].set_title(f"person {track}: trunk, shoulder elevation (ISB), elbow", fontsize=10)
        ax = axes[row, 2]
        pelvis = _track(result, p, "pelvis")
        ax.plot(pelvis[:, 0], pelvis[:, 1], color="tab:green", linewidth=1.5, label="pelvis")
        ok = np.flatnonzero(np.isfinite(pelvis[:, 0]))
        if len(ok):
            ax.plot(*pelvis[ok[0], :2], "o", color="tab:green", label="start")
        ax.plot(cams[:, 0], cams[:, 1], "k^", label="cameras")
        for c, camera in enumerate(result.cameras):
            ax.annotate(camera.name, cams[c, :2], fontsize=7, xytext=(3, 3), textcoords="offset points")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"person {track}: pelvis path from above", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
        ax = axes[row, 3]
        ankles = np.stack([_track(result, p, "right_ankle"), _track(result, p, "left_ankle")])  # (2, T, 3)
        (right, left), label = ankle_heights(ankles, (result.meta or {}).get("floor"))
        ax.plot(times, 100 * right, color="tab:red", label="right ankle")
        ax.plot(times, 100 * left, color="tab:blue", label="left ankle")
        ax.set_xlabel("time (s)")
        ax.set_ylabel(label)
        ax.set_title(f"person {track}: ankle heights", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as stream:
            fig.savefig(stream, format="png")
    return path
