"""The end of a lift's console output: the files written and how to open the recording."""

from __future__ import annotations

from platypose.cli.console import LISTED_INPUTS, written_lines


def test_lift_lists_the_files_it_wrote_and_the_command_to_open_the_recording(tmp_path):
    folder = tmp_path / "take"
    ok = {"name": "take", "status": "ok", "outputs": [str(folder / "take.npz"), str(folder / "take.rrd")]}
    failed = {"name": "bad", "status": "failed", "outputs": []}
    assert written_lines([ok, failed]) == [
        f"take: wrote take.npz, take.rrd in {folder}/",
        f"  look at it: rerun {folder / 'take.rrd'}",
    ]
    many = [{**ok, "name": f"t{i}"} for i in range(LISTED_INPUTS + 1)]
    assert written_lines(many)[0] == f"t0: 2 files in {folder}/" and len(written_lines(many)) == LISTED_INPUTS + 1


def test_resume_does_not_say_it_wrote_the_files_of_inputs_it_skipped(tmp_path):
    folder = tmp_path / "take"
    skipped = {"name": "take", "status": "skipped", "outputs": [str(folder / "take.npz")]}
    assert written_lines([skipped]) == [f"take: kept, unchanged since an earlier run: take.npz in {folder}/"]
