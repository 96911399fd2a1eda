"""``export``: write the requested files of one result into its output folder."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

import numpy as np

from platypose.exporters.angles import angle_series, write_angles_csv
from platypose.exporters.bvh import write_bvh
from platypose.exporters.csv_export import write_long_csv, write_people_csv
from platypose.exporters.frames import Lead
from platypose.exporters.npz import write_npz
from platypose.exporters.result import LiftResult
from platypose.lifting.errors import InputError

FORMATS = ("npz", "csv", "csv-long", "bvh", "trc", "c3d", "angles", "mot", "report", "rrd")
BVH_MODES = ("median", "all")
# Formats holding every frame, absent ones filled by the rule of exporters.gaps (listed in <name>_gaps.json).
FILLED_FORMATS = ("csv", "csv-long", "bvh", "trc", "c3d", "angles", "mot")


def parse_formats(text: str | Iterable[str]) -> tuple[str, ...]:
    """Formats from ``"csv,bvh"`` or a list, in canonical order; InputError on an unknown one."""
    items = [s.strip().lower() for s in (text.split(",") if isinstance(text, str) else text) if s.strip()]
    unknown = sorted(set(items) - set(FORMATS))
    if unknown or not items:
        given = ", ".join(unknown) or repr(text)
        raise InputError(f"formats: unknown or empty {given}; choose from {','.join(FORMATS)}", option="formats")
    return tuple(f for f in FORMATS if f in items)


def _write_bvhs(result: LiftResult, out_dir: Path, name: str, mode: str) -> tuple[list[Path], dict]:
    """BVH files per person (median, and every hypothesis with mode 'all') and their fit errors for meta."""
    paths: list[Path] = []
    errors: dict[str, dict] = {}
    present = result.present()
    for p, track in enumerate(result.track_ids):
        if not present[p].any():
            continue
        path = out_dir / f"{name}_p{track}.bvh"
        errors[f"p{track}"] = {
            "median": write_bvh(Lead(result.median, p), result.fps, path, result.frame_times).as_dict()
        }
        paths.append(path)
        if mode == "all":
            fits = []
            for n in range(result.num_hypotheses):
                hyp_path = out_dir / f"{name}_p{track}_h{n:03d}.bvh"
                fits.append(write_bvh(Lead(result.hypotheses, p, n), result.fps, hyp_path, result.frame_times))
                paths.append(hyp_path)
            errors[f"p{track}"]["hypotheses"] = {
                "mean_m": float(np.mean([f.mean_m for f in fits])),
                "max_m": float(np.max([f.max_m for f in fits])),
            }
    return paths, errors


def _write_markers(result: LiftResult, out_dir: Path, name: str, formats: tuple[str, ...]) -> list[Path]:
    """TRC and/or C3D files per person: the median motion, gaps filled by the rule of :mod:`exporters.gaps`."""
    from platypose.exporters.c3d_export import write_c3d
    from platypose.exporters.gaps import fill_frames, person_plans
    from platypose.exporters.markers import read_frames
    from platypose.exporters.trc import write_trc

    paths: list[Path] = []
    for p, plan in person_plans(result).items():
        track = result.track_ids[p]
        filled = fill_frames(read_frames(Lead(result.median, p)), plan, slice(None))
        if "trc" in formats:
            paths.append(write_trc(filled, result.frame_times, result.fps, out_dir / f"{name}_p{track}.trc"))
        if "c3d" in formats:
            paths.append(write_c3d(filled, ~plan.filled, result.fps, out_dir / f"{name}_p{track}.c3d"))
    return paths


def _write_gaps(result: LiftResult, out_dir: Path, name: str, say: Callable[[str], None]) -> Path:
    """The gaps sidecar ``<name>_gaps.json`` (every person's filled frames), each person's gaps logged."""
    from platypose.exporters.gaps import describe_gaps, find_gaps, gaps_sidecar, person_plans

    gaps = {}
    for p, plan in person_plans(result).items():
        track = int(result.track_ids[p])
        gaps[f"p{track}"] = find_gaps(plan, result.frame_times)
        say(f"{name}: person {track} gaps: {describe_gaps(gaps[f'p{track}'])}")
    return gaps_sidecar(out_dir / f"{name}_gaps.json", gaps)


def export(
    result: LiftResult,
    out_dir: Path | str,
    name: str,
    formats: Iterable[str] = FORMATS,
    video_paths: Mapping[str, Path] | None = None,
    bvh: str = "median",
    rrd_video: str = "asset",
    say: Callable[[str], None] = lambda _: None,
    warn: Callable[[str], None] | None = None,
    playable: Mapping[str, Path] | None = None,
) -> list[Path]:
    """Write ``formats`` of ``result`` as ``out_dir/name*``; return the paths written. Each file is atomic.

    ``playable``: videos (by camera, as ``video_paths``) already made playable for the recording (re-encoded
    beside the lift: ``platypose.cli.runs.playable``), which it embeds in place of those of ``video_paths``; the
    others are re-encoded while it is written, where rerun cannot play them.

    Progress goes to ``say``; a warning about a person's export (OpenSim IK that fits badly) to ``warn``, by default
    said as ``warning: <name>: ...`` (``lift`` keeps them in its log, summary and console).

    The BVH fit error goes into ``meta["bvh_fit_error"]`` and OpenSim's IK fit into ``meta["opensim_ik"]`` of the
    npz written in the same call.
    """
    formats = parse_formats(formats)
    if bvh not in BVH_MODES:
        raise InputError(f"bvh must be one of {', '.join(BVH_MODES)}, got {bvh!r}", option="bvh")
    out_dir = Path(out_dir)
    if "mot" in formats:
        from platypose.exporters.mot import load_opensim

        load_opensim()  # the one-line error before anything is written
    if "rrd" in formats or "report" in formats:  # both cut pictures from the videos: checked before writing
        from platypose.exporters.rrd import check_videos

        videos = {k: Path(v) for k, v in (video_paths or {}).items()}
        check_videos(result, videos, rrd_video if "rrd" in formats else "asset")
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    collapsed = result.collapsed() if set(formats) & set(FILLED_FORMATS) else []
    for track in collapsed:
        say(
            f"{name}: person {track}: every frame's joints lie within a few centimetres of one point (a collapsed "
            f"lift, no body): no {', '.join(f for f in formats if f in FILLED_FORMATS)} written for this person"
        )
    if "bvh" in formats:
        say(f"{name}: BVH ({bvh})")
        paths, errors = _write_bvhs(result, out_dir, name, bvh)
        written += paths
        result = result.with_meta(bvh_fit_error=errors)
    if "mot" in formats:
        from platypose.exporters.mot import flag_ik, write_mots

        say(f"{name}: OpenSim scaling and inverse kinematics")
        paths, fits = write_mots(result, out_dir, name, say, warn or (lambda text: say(f"warning: {name}: {text}")))
        written += paths
        reports = flag_ik(result.meta.get("plausibility") or [], fits, result.track_ids)
        result = result.with_meta(opensim_ik=fits, **({"plausibility": reports} if reports else {}))
    series = angle_series(result) if {"npz", "angles", "report"} & set(formats) else {}
    if "npz" in formats:
        say(f"{name}: npz")
        written.append(write_npz(result, out_dir / f"{name}.npz", series))
    if "csv" in formats:
        say(f"{name}: CSV")
        written.append(write_people_csv(result, out_dir / f"{name}.csv"))
    if "csv-long" in formats:
        say(f"{name}: CSV of every hypothesis")
        written.append(write_long_csv(result, out_dir / f"{name}_hypotheses.csv"))
    if "trc" in formats or "c3d" in formats:
        say(f"{name}: {' and '.join(f.upper() for f in formats if f in ('trc', 'c3d'))} markers")
        written += _write_markers(result, out_dir, name, formats)
    who = ({}, {})  # per person: good frame and thumbnail (exporters.person_pictures; an estimated camera's horizon
    # drawn in it, exporters.horizon), for report and recording
    if "report" in formats or "rrd" in formats:
        from platypose.exporters.horizon import reach_horizons, with_horizons
        from platypose.exporters.person_pictures import good_frames, thumbnails

        frames = reach_horizons(result, good_frames(result))
        pictures = thumbnails(result, {k: Path(v) for k, v in (video_paths or {}).items()}, frames)
        who = (frames, with_horizons(result, frames, pictures))
        unseen = sorted({result.cameras[f.camera].name for p, f in frames.items() if p not in who[1]})
        if unseen:
            say(
                f"{name}: no person thumbnails from camera(s) {', '.join(unseen)}: no video of them (--video CAMERA=PATH)"
            )
    if "angles" in formats or "report" in formats:
        if "angles" in formats:
            say(f"{name}: joint angles")
            written.append(write_angles_csv(result, series, out_dir / f"{name}_angles.csv"))
        if "report" in formats:
            from platypose.exporters.report import write_report

            say(f"{name}: report picture")
            written.append(write_report(result, series, name, out_dir / f"{name}_report.png", who))
    if set(formats) & set(FILLED_FORMATS):
        written.append(_write_gaps(result, out_dir, name, say))
    if "rrd" in formats:
        from platypose.exporters.rrd import write_rrd

        say(f"{name}: rerun recording")
        embedded = {**(video_paths or {}), **(playable or {})}
        written.append(write_rrd(result, out_dir / f"{name}.rrd", name, embedded, rrd_video, say, who))
    return written
