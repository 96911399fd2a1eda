"""``platypose eval --sets``: each unseen set evaluated on its own; ``--heldout`` never scores calibration clips."""

from __future__ import annotations

import json
from dataclasses import replace

from platypose.lifting.offline.calibration import calibration_clip_names
from platypose.lifting.prior.model import load_prior, save_prior


def test_each_set_gets_its_own_table(run_cli, prior_file, data_dir, tmp_path):
    (tmp_path / "deepmimic").symlink_to(data_dir / "motion/deepmimic")
    spec = tmp_path / "unseen.json"
    spec.write_text(
        json.dumps(
            {
                "walks": ["deepmimic/humanoid3d_walk.txt"],
                "more": ["deepmimic/humanoid3d_r*", "deepmimic/humanoid3d_jump.txt"],
            }
        )
    )
    out_json = tmp_path / "eval.json"
    code, out, err = run_cli(
        "eval", "--sets", spec, "--prior", prior_file, "--frames", "1,8", "--samples", "6", "--windows", "1",
        "--views", "1", "--no-baseline", "--json", out_json,
    )  # fmt: skip
    assert code == 0, err
    assert "set walks: 1 clips" in out and "set more: 3 clips" in out  # roll, run, jump
    tables = json.loads(out_json.read_text())["sets"]
    assert list(tables) == ["walks", "more"] and all([r["frames"] for r in rows] == [1, 8] for rows in tables.values())
    assert tables["walks"][0]["windows"] == 1 and tables["more"][0]["windows"] == 3


def test_motion_and_sets_together_are_one_line(run_cli, prior_file, data_dir):
    code, _, err = run_cli("eval", data_dir / "motion/deepmimic", "--sets", data_dir / "motion/unseen.json")
    assert code == 2 and "not both" in err and len(err.strip().splitlines()) == 1


def test_heldout_leaves_out_the_clips_a_temperature_was_fitted_on(run_cli, prior_file, data_dir, tmp_path):
    bundle, _ = load_prior(prior_file)
    validation = [c["name"] for c in bundle.manifest["clips"] if c["split"] == "validation"]
    fitted = calibration_clip_names(bundle.manifest)
    assert len(validation) >= 2 and fitted
    calibrated = tmp_path / "calibrated.pt"
    manifest = {**bundle.manifest, "temperature": {"by_frames": {"1": 1.0}}}
    save_prior(calibrated, replace(bundle, manifest=manifest))
    counts = {}
    for prior in (prior_file, calibrated):
        code, out, err = run_cli(
            "eval", data_dir / "motion/deepmimic", data_dir / "motion/holosoma-climb", "--heldout", "--prior", prior,
            "--frames", "1", "--samples", "4", "--windows", "1", "--views", "1", "--no-baseline",
        )  # fmt: skip
        assert code == 0, err
        counts[prior] = int(out.split(" clips,")[0].split()[-1])
    assert counts[prior_file] == len(validation) and counts[calibrated] == len(validation) - len(fitted)
