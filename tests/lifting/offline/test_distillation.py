"""Progressive distillation: the halving plan, the two-step target, a resumable run and the student's sampling."""

import numpy as np
import pytest
import torch

from platypose.lifting.offline.distillation import END, distil_prior, halving_plan, two_step_target
from platypose.lifting.prior.model import load_prior
from platypose.lifting.prior.schedule import DiffusionSchedule, sampling_steps
from platypose.lifting.settings import DistilConfig

TEACHER_STEPS = sampling_steps(10, 2)  # the shipped sampler's 8 calls: 38, 32, 27, 21, 16, 10, 5, 0


def test_ddim_prediction_inverts_a_ddim_step_per_row():
    schedule = DiffusionSchedule()
    gen = torch.Generator().manual_seed(0)
    x_t, x_prev = torch.randn(3, 5, 51, generator=gen), torch.randn(3, 5, 51, generator=gen)
    t, t_prev = torch.tensor([38, 27, 16]), torch.tensor([27, 16, 5])
    x0 = schedule.ddim_prediction(x_t, x_prev, t, t_prev)
    assert torch.allclose(schedule.ddim_step(x_t, x0, t, t_prev), x_prev, atol=1e-5)


def test_halving_plan_pairs_the_teachers_steps():
    plan = halving_plan(TEACHER_STEPS, 4)
    assert plan.tolist() == [[38, 32, 27], [27, 21, 16], [16, 10, 5], [5, 0, END]]
    assert halving_plan(plan[:, 0], 2).tolist() == [[38, 27, 16], [16, 5, END]]  # a second round: 4 -> 2 calls
    with pytest.raises(ValueError, match="--calls must be 4"):
        halving_plan(TEACHER_STEPS, 3)


def test_the_target_does_two_teacher_steps_in_one(tiny_prior):
    """One DDIM step with the target lands where the teacher's two steps land; the last pair's target is the
    teacher's final prediction."""
    schedule = DiffusionSchedule()
    teacher = tiny_prior.model.eval()
    plan = torch.as_tensor(halving_plan(TEACHER_STEPS, 4))
    x_t = torch.randn(4, 8, 51, generator=torch.Generator().manual_seed(1))
    target = two_step_target(teacher, schedule, x_t, plan)
    with torch.no_grad():
        for row, (t, middle, following) in enumerate(plan.tolist()):
            x = x_t[row : row + 1]
            x_middle = schedule.ddim_step(x, teacher(x, torch.tensor(t)), t, middle)
            x0_middle = teacher(x_middle, torch.tensor(middle))
            if following == END:
                assert torch.allclose(target[row], x0_middle[0], atol=1e-5)
            else:
                two_steps = schedule.ddim_step(x_middle, x0_middle, middle, following)
                one_step = schedule.ddim_step(x, target[row : row + 1], t, following)
                assert torch.allclose(one_step, two_steps, atol=1e-4)


def _distil(real_clips, teacher, path, iterations, resume=None, log=None):
    config = DistilConfig(iterations=iterations, batch_size=8, checkpoint_every=3, validate_every=3, learning_rate=1e-3)
    torch.set_num_threads(1)
    return distil_prior(real_clips, teacher, TEACHER_STEPS, str(path), config, resume=resume, log=log)


def test_a_distilled_student_keeps_the_teachers_manifest_and_resumes_to_the_same_weights(
    real_clips, tiny_prior, tmp_path
):
    losses = []
    whole = _distil(real_clips, tiny_prior, tmp_path / "whole.pt", 6, log=losses.append)
    assert [entry["iteration"] for entry in losses] == [0, 3, 6]
    assert losses[-1]["val_loss"] < losses[0]["val_loss"]  # the student moves toward the two-step targets
    student, extra = load_prior(tmp_path / "whole.pt")
    assert extra == {}  # the finished checkpoint holds no training state
    assert student.fixed_steps.tolist() == [38, 27, 16, 5]
    assert student.manifest["clips"] == tiny_prior.manifest["clips"]
    assert student.manifest["licences"] == tiny_prior.manifest["licences"]
    assert student.manifest["distilled"]["teacher_steps"] == TEACHER_STEPS.tolist()
    for name, value in whole.model.state_dict().items():
        assert torch.equal(value, student.model.state_dict()[name])

    def interrupt(entry: dict) -> None:
        if entry["iteration"] == 6:  # after the checkpoint of iteration 3, before that of 6
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        _distil(real_clips, tiny_prior, tmp_path / "part.pt", 6, log=interrupt)
    part, state = load_prior(tmp_path / "part.pt")
    assert state["iteration"] == 3
    _distil(real_clips, tiny_prior, tmp_path / "part.pt", 6, resume=state)
    resumed, _ = load_prior(tmp_path / "part.pt")
    for name, value in student.model.state_dict().items():
        assert torch.equal(value, resumed.model.state_dict()[name]), name


def test_the_sampler_calls_a_distilled_prior_at_its_steps(real_clips, tiny_prior, tmp_path, heldout_window):
    """Four calls at the student's steps, guidance between them: four views still land on the truth."""
    from platypose.lifting.camera import project
    from platypose.lifting.offline import metrics
    from platypose.lifting.offline.camera_rigs import ring_cameras
    from platypose.lifting.sampling.sampler import cameras_and_rays, network_steps, sample
    from platypose.lifting.settings import SamplerConfig

    _distil(real_clips, tiny_prior, tmp_path / "student.pt", 3)
    student, _ = load_prior(tmp_path / "student.pt")
    assert network_steps(student, SamplerConfig()).tolist() == [38, 27, 16, 5]
    assert network_steps(tiny_prior, SamplerConfig()).tolist() == TEACHER_STEPS.tolist()
    with pytest.raises(ValueError, match="ddim solver"):
        network_steps(student, SamplerConfig(solver="dpm2m"))
    cams = ring_cameras(4)
    pixels = np.stack([project(heldout_window, c) for c in cams])[:, None]
    obs, rays = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]))
    called = []
    hook = student.model.register_forward_hook(lambda module, args, out: called.append(int(args[1])))
    result = sample(student, obs, rays, SamplerConfig(samples=20), frames=len(heldout_window))
    hook.remove()
    assert called == [38, 27, 16, 5]
    assert metrics.min_mpjpe(result.joints[0], heldout_window) < 0.005


def test_train_distil_from_cli(run_cli, data_dir, prior_file, tmp_path):
    out = tmp_path / "student.pt"
    options = ["--iterations", "2", "--batch-size", "4", "--checkpoint-every", "2", "--threads", "1", "--quiet"]
    code, _, err = run_cli("train", str(data_dir / "motion"), "--out", str(out), "--distil-from", prior_file, *options)
    assert code == 0, err
    code, info, _ = run_cli("prior-info", str(out))
    assert code == 0 and "2 iterations: 4 calls at steps 38, 27, 16, 5" in info
    code, _, err = run_cli(
        "train", str(data_dir / "motion"), "--out", str(out), "--distil-from", prior_file, "--calls", "3"
    )
    assert code == 2 and "--calls must be 4" in err and prior_file in err
