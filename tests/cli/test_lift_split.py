"""``platypose lift --split-seconds``: one input's detection and lifting spread over piece tasks and joined (runs/pieces.py and
runs/split.py), on the real sports2d demo video and its MoveNet detections with the session's tiny prior: pieces detect
exactly the frames of an unsplit run, persons keep their hypotheses through a crossing at a seam, a resumed split
redoes only the pieces that had not finished, a piece that fails (or whose worker dies) once is run again, bad values
are one line."""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from demo_tracks import demo_take, demo_tracks

from platypose.cli.runs.batch import run_batch
from platypose.cli.runs.job import run_job
from platypose.cli.runs.jobs import discover_jobs
from platypose.cli.runs.models import cached_detector
from platypose.cli.runs.pieces import PIECES
from platypose.cli.runs.pools import LocalPieces
from platypose.cli.runs.settings import RunSettings
from platypose.cli.runs.split import SplitExecutor, piece_hooks
from platypose.lifting.job_log import JobLog
from platypose.lifting.settings import DetectOptions, PriorSettings, SamplerConfig, TakeSettings, WindowSettings

DEMO = "video/sports2d-demo"


class InProcess:
    """A piece pool that runs the tasks here, one after another; ``stop_at``: raise ``error`` before that task."""

    def __init__(self, stop_at: int | None = None, error: type[BaseException] = RuntimeError) -> None:
        self.stop_at, self.error, self.ran = stop_at, error, []

    def __enter__(self) -> InProcess:
        return self

    def __exit__(self, *failure) -> None:
        return None

    def run(self, tasks, names, each=lambda i: None, say=lambda _: None) -> list:
        results = []
        for i, (fn, args) in enumerate(tasks):
            if len(self.ran) == self.stop_at:
                raise self.error("stopped")
            results.append(fn(*args))
            self.ran.append(names[i])
            each(i)
        return results


def seed_detections(data_dir, video: Path, folder: Path) -> None:
    """The bundled MoveNet detections of ``video`` as its detection cache in ``folder`` (nothing is detected)."""
    from platypose.detectors.cache import DetectionCache, cache_key, read_detections

    options = DetectOptions(threads=1)
    name = cached_detector(options).name
    _, detections, indices = read_detections(data_dir / DEMO / "movenet-detections.npz")
    folder.mkdir(parents=True, exist_ok=True)
    DetectionCache(folder, video.stem).save(cache_key(video, name, 1, None), detections, indices)


def test_pieces_detect_the_frames_of_an_unsplit_run(data_dir, tmp_path):
    """Every 10th frame of the demo video detected in 3 s pieces (seeks into the video) is what one pass detects:
    the same frame indices and the same keypoints, written as the video's detection cache."""
    from platypose.cli.runs.split import detect_in_pieces
    from platypose.detectors.cache import DetectionCache, cache_key
    from platypose.detectors.video_detection import detect_frames

    video = data_dir / DEMO / "demo.mp4"
    options = DetectOptions(threads=1, stride=10)
    pool = InProcess()
    log = JobLog()
    assert detect_in_pieces(video, options, tmp_path / "demo", 3.0, pool, log) == 3
    assert len(pool.ran) == 3 and "3 piece(s) of 3 s detected in" in log.lines[0]  # frames 0-89, 90-179, 180-end
    model = cached_detector(options)
    joined = DetectionCache(tmp_path / "demo", "demo").load(cache_key(video, model.name, 10, None))
    detections, indices = detect_frames(video, model, stride=10)
    assert np.array_equal(joined[1], indices) and np.array_equal(indices, np.arange(0, 230, 10))
    assert all(np.array_equal(a, b) for a, b in zip(joined[0], detections))


def test_persons_keep_their_hypotheses_through_a_crossing_at_a_seam(data_dir, tiny_prior, prior_file, tmp_path):
    """The walker of the demo and his mirror image cross at frame 114; split there (pieces of 3.8 s), each person's
    joined median reprojects onto that person's own keypoints around the seam (no swap of identities in the lift)
    about as closely as the unsplit lift's and far from the other person's, and persons are absent in exactly the
    frames they are in the unsplit lift."""
    from platypose.cli.runs.split import SplitLifter
    from platypose.lifting.calibration import load_calibration
    from platypose.lifting.camera import project
    from platypose.lifting.take import Take
    from platypose.lifting.tracks.persons import lift_persons

    walker = demo_tracks().keypoints[:, 1]
    times = demo_tracks().frame_times
    mirror = walker.copy()
    mirror[..., 0] = 1768 - walker[..., 0]
    keypoints = np.stack([walker, mirror], axis=1)[None]  # (1, T, 2, 17, 3)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        centre = np.nanmedian(keypoints[0, :, :, :, 0], axis=-1)  # (T, 2), NaN where unseen
    crossing = int(np.nanargmin(np.abs(centre[:, 0] - centre[:, 1])))
    assert 100 < crossing < 130
    camera = load_calibration(data_dir / DEMO / "Calib_demo.toml").camera("demo")
    windows, config = WindowSettings(max_gap=1.0), SamplerConfig(samples=4, seed=3)
    take = Take.on_clock(keypoints, times, np.arange(2), [camera], [None, None], sampler=config, windows=windows)
    absent = take.absent
    pool = InProcess()
    split = SplitLifter(pool, PriorSettings(path=prior_file), float(times[crossing] - times[0]), tmp_path, str)
    medians = {}
    for name, lifter in (("whole", lift_persons), ("split", split)):
        hypotheses = np.empty((2, 4, len(times), 17, 3), np.float32)
        medians[name] = np.empty((2, len(times), 17, 3), np.float32)
        energy = np.empty((2, 4, len(times)), np.float32)
        lifter(tiny_prior, take, hypotheses=hypotheses, median=medians[name], energy=energy)
        assert np.array_equal(np.isnan(hypotheses).all(axis=(1, 3, 4)), absent)
    assert pool.ran == ["0 (frames 0-144)", "1 (frames 85-229)"]  # one seam, at the crossing
    near = slice(crossing - 15, crossing + 15)
    for p in range(2):
        projected = {name: project(m[p, near], camera)[..., :2] for name, m in medians.items()}
        own = {
            name: np.nanmedian(np.linalg.norm(xy - keypoints[0, near, p, :, :2], axis=-1))
            for name, xy in projected.items()
        }
        other = np.nanmedian(np.linalg.norm(projected["split"] - keypoints[0, near, 1 - p, :, :2], axis=-1))
        assert own["split"] < 1.5 * own["whole"] + 5, own
        assert other > 3 * own["split"], (other, own)  # 163 px against 38 px


def lift_settings_for(data_dir, prior_file, out: Path) -> RunSettings:
    """Settings of a split lift of the demo (3 s pieces), 4 hypotheses, npz only."""
    take = TakeSettings(sampler=SamplerConfig(samples=4, seed=3), windows=WindowSettings(max_gap=1.0))
    return RunSettings(
        out=out, cams=data_dir / DEMO / "Calib_demo.toml", prior=PriorSettings(path=Path(prior_file)),
        detect=DetectOptions(threads=1), take=take, formats=("npz",), quiet=True, split_seconds=3.0,
    )  # fmt: skip


def test_a_resumed_split_redoes_only_the_pieces_left(data_dir, prior_file, tmp_path):
    """A split lift interrupted after its first piece keeps that piece; ``--resume`` lifts the other two and writes
    the same arrays as a split lift run in one go; the piece folder goes once the files are written."""
    from platypose.exporters.npz import read_npz

    video = data_dir / DEMO / "demo.mp4"
    (job,) = discover_jobs([video])
    results = {}
    for run in ("interrupted", "in one go"):
        settings = lift_settings_for(data_dir, prior_file, tmp_path / run)
        seed_detections(data_dir, video, tmp_path / run / job.name)
        if run == "interrupted":
            with pytest.raises(KeyboardInterrupt):
                run_job(job, settings, hooks=piece_hooks(InProcess(stop_at=1, error=KeyboardInterrupt), settings))
            assert len(list((tmp_path / run / job.name / PIECES).glob("lift.*.npz"))) == 1
            assert not (tmp_path / run / job.name / "lift.json").exists()
        pool = InProcess()
        (entry,) = run_batch(
            [job], settings, resume=True, executor=SplitExecutor(lambda threads, quiet, pool=pool: pool)
        )
        assert entry["status"] == "ok", entry
        assert len(pool.ran) == (2 if run == "interrupted" else 3)
        assert not (tmp_path / run / job.name / PIECES).exists()
        results[run] = read_npz(tmp_path / run / job.name / "demo.npz")
    a, b = results.values()
    assert list(a.track_ids) == list(b.track_ids) == [0, 1]
    assert np.array_equal(a.hypotheses, b.hypotheses, equal_nan=True)
    assert np.array_equal(a.median, b.median, equal_nan=True)


def fails_once(marker: str) -> None:
    """A piece task that fails the first time it runs (it leaves ``marker``), then succeeds."""
    if not os.path.exists(marker):
        Path(marker).touch()
        raise RuntimeError("a transient failure")


def dies_once(marker: str) -> None:
    """A piece task whose worker process dies the first time (it leaves ``marker``)."""
    if not os.path.exists(marker):
        Path(marker).touch()
        os._exit(3)


def always_fails(marker: str) -> None:
    """A piece task that always fails."""
    raise RuntimeError(f"broken {Path(marker).name}")


def test_a_piece_that_fails_once_is_run_again(tmp_path):
    """On this machine's processes, a piece task that raises, or whose worker dies, once is run again and the split
    goes on; one that fails twice stops it with a line naming the piece."""
    with LocalPieces(2, 1) as pool:  # raised: run again in the same pool, each rerun said
        done, said = [], []
        pool.run([(fails_once, (str(tmp_path / name),)) for name in "ac"], ["0", "2"], done.append, said.append)
        assert sorted(done) == [0, 1]
        assert "piece 0 failed (RuntimeError: a transient failure); running it again" in said
        assert "piece 2 failed (RuntimeError: a transient failure); running it again" in said
    with LocalPieces(2, 1) as pool:  # a worker died: the pool's pieces run again in new processes, said once
        done, said = [], []
        pool.run([(dies_once, (str(tmp_path / "b"),))], ["1"], done.append, said.append)
        assert done == [0]
        died = [line for line in said if line.startswith("a worker process died; running piece(s) ")]
        assert died and "1" in died[0].split("piece(s) ")[1], said
        with pytest.raises(RuntimeError, match="piece 7 failed 2 times: RuntimeError: broken x"):
            pool.run([(always_fails, (str(tmp_path / "x"),))], ["7"])


def test_on_ray_a_piece_whose_worker_dies_is_run_again(tmp_path):
    """On Ray (a private 2-CPU instance), a piece task whose worker dies once is run again by Ray."""
    import ray

    from platypose.cli.runs.pools import RayPieces

    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the task function is this module's
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    try:
        done = []
        RayPieces(ray, 1, 2, 1).run([(dies_once, (str(tmp_path / "b"),))], ["0"], done.append)
        assert done == [0] and (tmp_path / "b").exists()
    finally:
        ray.shutdown()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--split-seconds", "0", "--jobs", "2"], "--split-seconds 0: give a length in seconds above 0"),
        (["--split-seconds=-3", "--jobs", "2"], "--split-seconds -3: give a length in seconds above 0"),
        (["--split-seconds", "nan", "--jobs", "2"], "--split-seconds nan: give a length in seconds above 0"),
        (["--split-seconds", "1e308", "--jobs", "2"], "--split-seconds 1e+308: give at most 86400 seconds (a day)"),
        (["--split-seconds", "1.5", "--max-gap", "1", "--jobs", "2"], "--split-seconds 1.5: shorter than the 2 s two"),
        (["--split-seconds", "3", "--jobs", "2"], "--split-seconds 3: shorter than the 10 s two neighbouring"),
        (["--split-seconds", "3", "--max-gap", "2", "--jobs", "2"], "shorter than the 4 s two neighbouring"),
        (["--split-seconds", "10"], "--split-seconds: the pieces run in parallel; add --jobs N (N >= 2) or --executor"),
        (["--split-seconds", "10", "--executor", "ray", "--collect"], "--split-seconds: not with --collect"),
    ],
)
def test_bad_split_values_are_one_line(run_cli, data_dir, tmp_path, extra, message):
    code, out, err = run_cli("lift", str(data_dir / DEMO / "demo.mp4"), "--out", str(tmp_path / "out"), "-q", *extra)
    assert code == 2, (out, err)
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], err
    assert not (tmp_path / "out" / "demo").exists()


@pytest.mark.parametrize("kind", ["symbolic link", "regular file"])
def test_a_piece_folder_that_is_not_a_folder_is_refused(data_dir, prior_file, tmp_path, kind):
    """``OUT/<name>/.pieces`` that is a symbolic link (to a folder outside --out) or a regular file fails the input
    with one line naming it, as ``.lift.lock`` is refused; nothing is written where the link leads."""
    video = data_dir / DEMO / "demo.mp4"
    (job,) = discover_jobs([video])
    settings = lift_settings_for(data_dir, prior_file, tmp_path / "out")
    seed_detections(data_dir, video, tmp_path / "out" / job.name)
    pieces, elsewhere = tmp_path / "out" / job.name / PIECES, tmp_path / "elsewhere"
    elsewhere.mkdir()
    if kind == "symbolic link":
        pieces.symlink_to(elsewhere)
    else:
        pieces.write_text("")
    entry = run_job(job, settings, hooks=piece_hooks(InProcess(), settings))
    assert entry["status"] == "failed" and entry["error_kind"] == "input", entry
    assert entry["error"] == f"{pieces}: is a {kind}, not the folder of pieces platypose made; remove it", entry
    assert list(elsewhere.iterdir()) == []


def deflated_zeros(path: Path) -> None:
    """A 4 MB-class npz of deflated zeros under a piece's name: arrays far larger than any piece, in a small file."""
    import io
    import zipfile

    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f4", "fortran_order": False, "shape": (2, 4, 10**6, 51)})
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        with archive.open("hypotheses.npy", "w", force_zip64=True) as member:
            member.write(header.getvalue())
            for _ in range(2 * 4 * 51 * 4):
                member.write(bytes(10**6))
        archive.writestr("energy.npy", header.getvalue())


def tampered(path: Path) -> None:
    """The piece with every coordinate moved by 1 m: shapes and values plausible, only the digest tells."""
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["hypotheses"] = arrays["hypotheses"] + 1.0
    with open(path, "wb") as stream:
        np.savez(stream, **arrays)


@pytest.mark.parametrize(
    "damage",
    [lambda path: os.truncate(path, 30000), deflated_zeros, tampered, lambda path: path.write_bytes(b"\0" * 100)],
    ids=["truncated", "deflated zeros", "tampered", "not an npz"],
)
def test_a_damaged_piece_is_warned_removed_and_lifted_again(data_dir, prior_file, tmp_path, damage):
    """After a split lift killed with one piece finished, that piece damaged (truncated to 30000 bytes, replaced by
    gigabytes of deflated zeros, its values changed, not an npz at all) is not read: the next run warns, removes it
    and lifts it again, and writes the arrays of a split lift that was never interrupted."""
    from platypose.exporters.npz import read_npz

    video = data_dir / DEMO / "demo.mp4"
    (job,) = discover_jobs([video])
    results = {}
    for run in ("damaged", "in one go"):
        settings = lift_settings_for(data_dir, prior_file, tmp_path / run)
        seed_detections(data_dir, video, tmp_path / run / job.name)
        if run == "damaged":
            with pytest.raises(KeyboardInterrupt):
                run_job(job, settings, hooks=piece_hooks(InProcess(stop_at=1, error=KeyboardInterrupt), settings))
            (piece,) = (tmp_path / run / job.name / PIECES).glob("lift.*.npz")
            damage(piece)
        pool = InProcess()
        entry = run_job(job, settings, hooks=piece_hooks(pool, settings))
        assert entry["status"] == "ok", entry
        assert len(pool.ran) == 3
        said = [w for w in entry["warnings"] if w.startswith("damaged split piece 0 (frames 0-")]
        assert len(said) == (1 if run == "damaged" else 0), entry["warnings"]
        assert run == "in one go" or f"{piece}: " in said[0] and said[0].endswith("; removed, lifted again")
        results[run] = read_npz(tmp_path / run / job.name / "demo.npz")
    a, b = results.values()
    assert np.array_equal(a.hypotheses, b.hypotheses, equal_nan=True)


def test_a_piece_read_back_is_checked_before_use(data_dir, prior_file, tmp_path):
    """A real piece's arrays are read back only as the lift wrote them: other shapes (checked in the npz headers,
    before loading), values not finite where a person is present, or coordinates over 1 km from the origin are
    one ValueError each saying so."""
    from platypose.cli.runs.piece_files import read_lift_piece

    video = data_dir / DEMO / "demo.mp4"
    (job,) = discover_jobs([video])
    settings = lift_settings_for(data_dir, prior_file, tmp_path)
    seed_detections(data_dir, video, tmp_path / job.name)
    with pytest.raises(KeyboardInterrupt):
        run_job(job, settings, hooks=piece_hooks(InProcess(stop_at=1, error=KeyboardInterrupt), settings))
    (piece,) = (tmp_path / job.name / PIECES).glob("lift.*.npz")
    with np.load(piece) as data:
        hypotheses, energy = data["hypotheses"], data["energy"]
    present = ~np.isnan(energy).all(axis=1)
    h, e = read_lift_piece(piece, present, 4)
    assert np.array_equal(h, hypotheses, equal_nan=True) and present.any()
    t = present.shape[1]
    with pytest.raises(
        ValueError, match=rf"arrays energy \(2, 4, {t}\) float32, .* \(2, 4, {t - 1}, 17, 3\) float32 were"
    ):
        read_lift_piece(piece, present[:, :-1], 4)
    p, t = np.argwhere(present)[0]
    for value, message in (
        (np.nan, "not finite in frames where a person is present"),
        (2e3, r"coordinates 2e\+03 m from the origin \(over 1000 m\)"),
    ):
        changed = hypotheses.copy()
        changed[p, 0, t, 3, 1] = value
        np.savez(tmp_path / "changed.npz", hypotheses=changed, energy=energy)
        with pytest.raises(ValueError, match=message):
            read_lift_piece(tmp_path / "changed.npz", present, 4)


def test_a_gap_cut_by_a_pieces_edge_is_lifted_by_the_neighbour(data_dir, tiny_prior, prior_file, tmp_path):
    """The demo's walker unseen for 0.67 s (frames 75-94) across the start of the second piece's margin (frame 84):
    that piece lifts her from her first seen frame on (it cannot bridge a gap whose start it does not hold), the
    first piece holds the whole gap and lifts through it, and the joined lift has her in every frame the take has
    her. (Checked against the whole take's presence, the second piece was called damaged, lifted again and the
    input failed: "values that are not finite in frames where a person is present", the 60 s clip split at 15 s.)"""
    from platypose.cli.runs.split import SplitLifter
    from platypose.lifting.calibration import load_calibration
    from platypose.lifting.take import Take

    tracks = demo_tracks()
    keypoints, times = tracks.keypoints[:, 1:2].copy()[None], tracks.frame_times
    keypoints[0, 75:95] = np.nan
    keypoints[0, 75:95, ..., 2] = 0.0
    camera = load_calibration(data_dir / DEMO / "Calib_demo.toml").camera("demo")
    windows, config = WindowSettings(max_gap=1.0), SamplerConfig(samples=2, seed=0)
    take = Take.on_clock(keypoints, times, np.array([1]), [camera], [None], sampler=config, windows=windows)
    assert not take.absent[0, 75:95].any()  # the take bridges the gap
    pool = InProcess()
    split = SplitLifter(pool, PriorSettings(path=prior_file), float(times[114] - times[0]), tmp_path, str)
    hypotheses = np.empty((1, 2, len(times), 17, 3), np.float32)
    median = np.empty((1, len(times), 17, 3), np.float32)
    energy = np.empty((1, 2, len(times)), np.float32)
    split(tiny_prior, take, hypotheses=hypotheses, median=median, energy=energy)
    assert pool.ran == ["0 (frames 0-143)", "1 (frames 84-229)"]
    assert np.isfinite(hypotheses[0][:, ~take.absent[0]]).all()
    assert np.isnan(hypotheses[0][:, take.absent[0]]).all()


def test_a_split_take_stands_on_the_unsplit_takes_floor(data_dir, tiny_prior, prior_file, tmp_path):
    """Without a calibration the floor is estimated under a quick lift of the whole take, split or not: the same
    plane and the same world (lifted in pieces, the 60 s clip's floor came out 2.7 cm lower, and everyone moved
    5-14 cm along their rays)."""
    from platypose.cli.runs.split import SplitLifter
    from platypose.lifting.floor import FloorToEstimate
    from platypose.lifting.tracks.persons import lift_persons
    from platypose.pipeline import lift_take

    take = demo_take(SamplerConfig(samples=2, seed=0), WindowSettings(max_gap=1.0))
    split = SplitLifter(InProcess(), PriorSettings(path=prior_file), 3.0, tmp_path, JobLog())
    floors = [
        lift_take(tiny_prior, take, floor=FloorToEstimate(), lifter=lifter).meta["floor"]
        for lifter in (lift_persons, split)
    ]
    assert floors[0]["source"] == "estimated" and floors[0] == floors[1]
