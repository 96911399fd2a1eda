"""load_motion / load_motion_paths dispatch: folders, skipped non-motion files, broken files, provenance."""

from __future__ import annotations

import json
import shutil
from collections import Counter

import numpy as np
import pytest

from platypose.lifting.errors import InputError
from platypose.lifting.motion_io import load_motion, load_motion_paths, supported_formats


def test_whole_bundled_motion_folder(data_dir):
    clips = load_motion_paths([data_dir / "motion"])
    formats = Counter(c.extra["format"] for c in clips)
    assert formats == {"deepmimic": 15, "holosoma": 5, "c3d": 4, "asf_amc": 2, "bvh": 1, "plain_npz": 196}
    assert all(c.licence != "unknown" and c.source != "unknown" for c in clips)
    minutes = sum(c.duration_s for c in clips) / 60
    assert 37.3 < minutes < 37.5  # docs/motion-data.md: 37.40 minutes of cleared real motion


def test_folder_skips_licences_and_reports_broken_motion(tmp_path, data_dir):
    shutil.copy(data_dir / "motion/mocapbank/test_mocapbank.bvh", tmp_path / "a.bvh")
    (tmp_path / "LICENSE.txt").write_text("MIT licence text")
    (tmp_path / "notes.json").write_text(json.dumps({"hello": 1}))
    (tmp_path / "SOURCE.json").write_text(json.dumps({"source": "my lab", "licence": "CC-BY-4.0"}))
    sub = tmp_path / "sub"
    sub.mkdir()
    shutil.copy(data_dir / "motion/holosoma-climb/mocap_climb_seq_4_joint_positions_f0-2303.npy", sub / "b.npy")
    clips = load_motion_paths([tmp_path])
    assert [c.name for c in clips] == ["a", "b"]
    assert all((c.source, c.licence) == ("my lab", "CC-BY-4.0") for c in clips)
    (sub / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    with pytest.raises(InputError, match="broken.bvh"):
        load_motion_paths([tmp_path])


def test_single_file_errors(tmp_path):
    with pytest.raises(InputError, match="nothing.bvh.*no such file"):
        load_motion(tmp_path / "nothing.bvh")
    licence = tmp_path / "LICENSE.txt"
    licence.write_text("MIT")
    with pytest.raises(InputError, match="LICENSE.txt.*unknown motion format"):
        load_motion(licence)
    bad_source = tmp_path / "SOURCE.json"
    bad_source.write_text("{oops")
    npz = tmp_path / "x.npz"
    np.savez(npz, joints=np.zeros((2, 17, 3)), fps=30)
    with pytest.raises(InputError, match="SOURCE.json"):
        load_motion(npz)


def test_companion_files_say_what_to_load(data_dir):
    with pytest.raises(InputError, match="test.asf: this is an ASF skeleton; load its .amc"):
        load_motion(data_dir / "motion/cmu-asf-amc/test.asf")


def test_name_map_only_for_bvh_and_formats_listed(data_dir):
    with pytest.raises(InputError, match="test.amc.*name_map do not apply to asf_amc"):
        load_motion(data_dir / "motion/cmu-asf-amc/test.amc", name_map={"neck": "x"})
    text = supported_formats()
    for name in ("bvh", "asf_amc", "holosoma", "deepmimic", "h36m", "plain_npz", "c3d"):
        assert name in text
