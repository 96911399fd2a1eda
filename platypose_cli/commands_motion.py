"""``platypose motion info``: read motion files with the importers and show what a user needs to check them."""

from __future__ import annotations

import json
from pathlib import Path

import typer

motion_app = typer.Typer(
    help="Inspect real 3D motion files (BVH, ASF/AMC, holosoma, DeepMimic, H3.6M, npz, C3D).", no_args_is_help=True
)

NAME_MAP_HELP = "BVH only: JSON {our joint: BVH joint} for the 12 limb joints, 'neck' (skull base), optional 'head'."
SCALE_HELP = "BVH: metres per file unit (default: detected); DeepMimic: URDF scale (default 0.25)."


def _name_map(path: Path | None) -> dict[str, str] | None:
    from platypose.lifting.errors import InputError

    if path is None:
        return None
    try:
        mapping = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError) as err:
        raise InputError(f"{path}: name map must be a JSON object of our joint -> BVH joint names ({err})") from None
    if not isinstance(mapping, dict):
        raise InputError(f"{path}: name map must be a JSON object of our joint -> BVH joint names")
    return {str(k): str(v) for k, v in mapping.items()}


def _metres(value: float) -> str:
    return "n/a" if value != value else f"{value:.2f} m"


@motion_app.command("info")
def info(
    paths: list[Path] = typer.Argument(..., help="Motion files or folders (searched recursively)."),
    fps: float = typer.Option(None, "--fps", help="Frame rate to assume (overrides the file's or the format default)."),
    name_map: Path = typer.Option(None, "--name-map", help=NAME_MAP_HELP),
    scale: float = typer.Option(None, "--scale", help=SCALE_HELP),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object per clip instead of text."),
) -> None:
    """Show clips, frames, fps, duration, licence, height and per-bone median lengths of motion files."""
    from platypose.lifting.motion_io import load_motion_paths, supported_formats
    from platypose.lifting.motion_io.summary import motion_summary

    options = {k: v for k, v in {"name_map": _name_map(name_map), "scale": scale}.items() if v is not None}
    clips = load_motion_paths(paths, fps=fps, **options)
    if not clips:
        typer.echo(f"no motion files found; readable formats:\n{supported_formats()}", err=True)
        raise typer.Exit(1)
    for clip in clips:
        summary = motion_summary(clip)
        if as_json:
            typer.echo(json.dumps(summary))
            continue
        typer.echo(
            f"{summary['name']} [{summary['format']}]: {summary['frames']} frames at {summary['fps']:g} fps "
            f"= {summary['duration_s']:.2f} s; ankle-to-head {_metres(summary['ankle_to_head_m'])}, "
            f"head above pelvis {_metres(summary['head_above_pelvis_m'])}"
        )
        typer.echo(f"  source: {summary['source']}; licence: {summary['licence']}")
        if summary["missing_joints"]:
            typer.echo(f"  missing joints (NaN): {', '.join(summary['missing_joints'])}")
        bones = ", ".join(f"{k} {v:.3f}" for k, v in summary["bone_lengths_m"].items() if v == v)
        typer.echo(f"  median bone lengths (m): {bones}")
    total = sum(c.duration_s for c in clips)
    typer.echo(f"{len(clips)} clip(s), {total / 60:.2f} min in total", err=as_json)
