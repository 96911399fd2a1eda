"""Each person is lifted only where present: spans, rounds, and the numbers of persons present throughout."""

import numpy as np
import pytest
from demo_tracks import demo_tracks

from platypose.lifting.sampling.placement import Anchor
from platypose.lifting.sampling.sampler import cameras_and_rays, sample, window_key
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.timebase import interpolate, resample_keypoints
from platypose.lifting.tracks import stream as lift_module
from platypose.lifting.tracks.roots import presence
from platypose.lifting.tracks.stream import lift_stream, lift_tracks, person_spans, prior_clock
from platypose.lifting.tracks.windows import continuation_anchor, cut, plan_windows, stitch


@pytest.fixture(scope="module")
def sports_demo(data_dir):
    """Real MoveNet tracks of the Sports2D demo (C=1, T=230, P=2): the man is lost for 1.5 s while he jumps down,
    the woman walks in after 1.3 s and out before the end; the demo's default camera."""
    from platypose.lifting.calibration.defaults import default_camera

    tracks = demo_tracks()
    return tracks.keypoints[None], tracks.frame_times, default_camera("demo", *tracks.image_size)


def _whole_clip_reference(prior, camera, keypoints, times, config, settings):
    """Every person over every window of the whole clip, all persons in one batch (the lift before spans)."""
    clock = prior_clock(times, prior.fps)
    length = min(settings.window, prior.config.max_frames)
    plan = plan_windows(len(clock), length, min(settings.overlap, length // 2))
    resampled = np.moveaxis(resample_keypoints(np.moveaxis(keypoints, 1, 0), times, clock), 0, 1)  # (C, T', P, ..)
    windows = cut(np.moveaxis(resampled, 2, 1), plan, axis=2)  # (W, C, P, F, 17, 3)
    joints, previous = [], None
    for w, kp in enumerate(windows):
        start = int(round(clock[plan.starts[w]] * prior.fps))  # each person's window keyed by who and when
        keys = [window_key(config.seed, person, start) for person in range(kp.shape[1])]
        obs, rays = cameras_and_rays([camera], kp[..., :2], kp[..., 2])
        anchor = None
        if previous is not None:
            held, mask = continuation_anchor(previous, plan)
            anchor = Anchor(torch_tensor(held), torch_tensor(np.repeat(mask[None], kp.shape[1], 0)))
        result = sample(prior, obs, rays, config, plan.length, anchor=anchor, window_keys=keys)
        previous = result.fitted
        joints.append(np.moveaxis(np.asarray(result.joints, np.float32), 2, 0))  # (F, P, N, 17, 3)
    return np.moveaxis(interpolate(stitch(np.stack(joints), plan), clock, times), 0, 2).astype(np.float32)


def torch_tensor(values):
    import torch

    return torch.as_tensor(values, dtype=torch.float32)


def test_persons_present_throughout_lift_as_before(tiny_prior, data_dir):
    """Both persons of the balancing take are seen in every frame: spans are the whole clip, the two persons go
    through every window together, and the hypotheses are those of the whole-clip lift bit for bit."""
    from platypose.detectors.sources.keypoint_source import read_keypoints
    from platypose.lifting.calibration import load_calibration

    take = data_dir / "video/pose2sim-balancing"
    camera = load_calibration(take / "calib_pose2sim.toml").cameras[0]
    view = read_keypoints(take / "openpose-body25b/cam01_json", fps=60.0, image_size=(1080, 1920))
    keypoints, times = view.keypoints[None], view.frame_times  # (1, 100, 2, 17, 3)
    assert keypoints.shape[2] == 2 and presence(keypoints, times).all()
    config, settings = SamplerConfig(samples=3), WindowSettings(window=16, overlap=4)
    out = lift_tracks(tiny_prior, [camera], keypoints, times, config, settings)
    expected = _whole_clip_reference(tiny_prior, camera, keypoints, times, config, settings)
    assert out.hypotheses.shape == (2, 3, 100, 17, 3) and np.isfinite(out.hypotheses).all()
    assert np.array_equal(out.hypotheses, expected)


def test_each_person_is_sampled_only_where_present(tiny_prior, sports_demo, monkeypatch):
    """The network sees each person only over its spans; absent frames come out NaN, present ones finite; the
    two persons share network calls where both are there; chunks cover every frame once, in order."""
    keypoints, times, camera = sports_demo
    calls: list[tuple[int, int]] = []  # (windows in the batch, frames)
    original = lift_module.sample

    def recording(prior, obs, rays, sampler, frames, **rest):
        calls.append((obs.keypoints.shape[1], frames))
        return original(prior, obs, rays, sampler, frames, **rest)

    monkeypatch.setattr(lift_module, "sample", recording)
    settings = WindowSettings(window=16, overlap=4, max_gap=1.0)
    chunks = list(lift_stream(tiny_prior, [camera], keypoints, times, SamplerConfig(samples=2), settings))
    assert [c.start for c in chunks] == np.cumsum([0] + [c.hypotheses.shape[2] for c in chunks[:-1]]).tolist()
    hypotheses = np.concatenate([c.hypotheses for c in chunks], axis=2)  # (P, N, T, 17, 3)
    present = presence(keypoints, times)
    assert present.sum(1).tolist() == [181, 160]  # the man lost for 45 frames, the woman there for 160
    finite = np.isfinite(hypotheses).all(axis=(1, 3, 4))
    assert np.array_equal(finite, present)
    spans = person_spans(keypoints, times, prior_clock(times, tiny_prior.fps), 16, 4, max_gap=1.0)
    assert [(s.person, s.frames.start, s.frames.stop) for s in spans] == [(0, 0, 123), (0, 168, 226), (1, 38, 198)]
    sampled = sum(b * f for b, f in calls)
    assert sampled == sum(s.plan.count * s.plan.length for s in spans)
    whole_clip = 2 * plan_windows(len(prior_clock(times, tiny_prior.fps)), 16, 4).padded_total
    assert sampled < whole_clip, (sampled, whole_clip)
    assert max(b for b, _ in calls) == 2  # both persons in one network batch where their windows coincide


def test_a_detection_gap_is_lifted_through_as_one_motion(tiny_prior, sports_demo):
    """The man of the Sports2D demo is unseen for 1.5 s (frames 123-167): under the default --max-gap his track is one
    span, every frame of the gap is lifted, and windows that no camera sees carry each hypothesis on from where it
    was: his pelvis never steps by more across the gap than it does where he is seen (before, such windows fell
    back to a placement without rays, the origin, metres away)."""
    keypoints, times, camera = sports_demo
    clock = prior_clock(times, tiny_prior.fps)
    spans = person_spans(keypoints, times, clock, 16, 4, max_gap=5.0)
    assert [(s.person, s.frames.start, s.frames.stop) for s in spans] == [(0, 0, 226), (1, 38, 198)]
    settings = WindowSettings(window=16, overlap=4, max_gap=5.0)
    out = lift_tracks(tiny_prior, [camera], keypoints[:, :, :1], times, SamplerConfig(samples=4, seed=3), settings)
    pelvis = out.hypotheses[0, :, :226, 0]  # (N, T, 3)
    assert np.isfinite(pelvis).all()
    steps = np.linalg.norm(np.diff(pelvis, axis=1), axis=-1)  # (N, T - 1)
    seen_steps = np.concatenate([steps[:, :120], steps[:, 170:]], axis=1)
    assert steps[:, 122:168].max() <= 2 * seen_steps.max(), (steps[:, 122:168].max(), seen_steps.max())
    drift = np.linalg.norm(pelvis[:, 123:168] - pelvis[:, 122:123], axis=-1)  # from the last seen frame
    assert drift.max() < 10.0, drift.max()


def test_a_persons_lift_does_not_depend_on_who_else_is_lifted(tiny_prior, sports_demo):
    """Each window's noise is keyed by the person's identity and the window's start on the clock, not by its place in
    the network's batch: the woman of the Sports2D demo lifted alone (as ``--persons id:1`` or a piece of a split
    take holding only her) is bit for bit the woman lifted beside the man (before, her windows took the noise of
    whichever batch place they had, and her median pelvis moved by 5 cm median, 28 cm at most). Bit for bit where the
    network runs in bfloat16 (CPUs with AMX); in float32 a matrix product's rounding depends on its batch's size, which
    moves joints by hundredths of a millimetre, so there the test allows 0.1 mm."""
    keypoints, times, camera = sports_demo
    config, settings = SamplerConfig(samples=3, seed=2), WindowSettings(window=16, overlap=4, max_gap=1.0)
    both = lift_tracks(tiny_prior, [camera], keypoints, times, config, settings).hypotheses
    alone = lift_stream(tiny_prior, [camera], keypoints[:, :, 1:], times, config, settings, identities=[1])
    woman = np.concatenate([c.hypotheses for c in alone], axis=2)[0]
    present = np.isfinite(woman).all(axis=(0, 2, 3))
    assert present.sum() == 160
    np.testing.assert_allclose(woman[:, present], both[1][:, present], rtol=0, atol=1e-4)
    renamed = lift_stream(tiny_prior, [camera], keypoints[:, :, 1:], times, config, settings, identities=[7])
    other = np.concatenate([c.hypotheses for c in renamed], axis=2)[0]
    assert not np.allclose(other[:, present], woman[:, present])  # another identity draws other noise
