"""The sampler's settings: every knob of guided sampling, checked once."""

from __future__ import annotations

import math
from dataclasses import dataclass

from platypose.lifting.energy import ROBUST_LOSSES

STEP_RULES = ("backtrack", "paper")
DIRECTIONS = ("gauss-newton", "gradient")
SOLVERS = ("ddim", "dpm2m")
MAX_SAMPLES = 5000  # hypotheses per person: beyond this the arrays outgrow any machine for a minute of video


@dataclass(frozen=True)
class SamplerConfig:
    """Every knob of the sampler; defaults follow the paper (T=10, S=2, k=10) except where noted.

    ``energy_scale`` is the initial guidance step (lambda); ``decay`` cuts it when a
    step fails; ``step_rule`` "backtrack" rejects steps that raise the energy (or are
    not finite) and multiplies the step by ``grow`` after each accepted one, "paper"
    keeps every step and only cuts the scale. ``translation_smoothness``
    couples per-frame root offsets (0: independent frames; 100 keeps one view's root depth
    from jittering frame to frame). ``size_prior`` places each
    new network prediction where a person of typical adult size would stand (one
    view cannot tell a small near person from a tall far one; guidance then fits the
    pose at that place); ``size_spread`` gives each hypothesis its own size, typical
    times ``exp(size_spread * n)`` with n standard normal (adults' heights vary by
    about 4 %, their proportions more; 0: every hypothesis typical). With two or more
    cameras, ``noise_fit`` makes the last fit follow the keypoints only as far as their
    noise (measured from their own jitter) allows, against a prior on joint accelerations
    (:mod:`lifting.temporal_fit`); with one camera it smooths the keypoints' paths the same
    way before guidance fits them. With two or more cameras ``noise_spread`` moves each hypothesis by a draw of
    the joints' remaining uncertainty under that noise (:mod:`lifting.noise_spread`). ``bone_weight`` and
    ``symmetry_weight`` switch on the structural energies (metres squared). With one camera,
    ``depth_smoothness`` smooths every joint's depth path along its ray after each diffusion
    step's guidance (:mod:`lifting.depth_smoothing`; 0: off). ``solver`` re-noises each guided
    prediction for the next network call: "ddim" (eta as given) or "dpm2m", DPM-Solver++(2M), which
    also uses the guided prediction of the call before (:meth:`DiffusionSchedule.dpm_solver_2m_step`).
    ``floor`` ``(nx, ny, nz, d)`` (world metres, ``n`` up; None: no floor) grounds every hypothesis inside the
    sampler (:mod:`lifting.grounding`): ``floor_weight`` per squared metre of a joint below it, ``contact_weight``
    holding stance ankles on it, ``slide_weight`` against stance ankles sliding along it; and a window seen by
    one camera is placed where its stance ankles' rays meet it, where that keeps an adult's size; each
    hypothesis's stance ankles stand ``ANKLE_HEIGHT`` plus ``support_spread`` times a standard normal draw above it.
    ``temperature`` scales the initial noise the hypotheses start from (1: the prior as trained, the paper's;
    below 1 they start nearer its middle and spread less; what that trades is measured in docs/prior.md,
    "Temperature"). ``guidance_iters`` (k) is a maximum: guidance stops early once every hypothesis took a step
    gaining less than ``guidance_tol`` of its energy at the start of this diffusion step's guidance, or its step
    has shrunk to nothing (0: always k).
    """

    samples: int = 50
    steps: int = 10
    skip: int = 2
    eta: float = 0.0
    guidance_iters: int = 10
    guidance_tol: float = 1e-3
    energy_scale: float = 1.0
    decay: float = 0.1
    grow: float = 2.0
    step_rule: str = "backtrack"
    direction: str = "gauss-newton"
    damping: float = 0.1
    robust: str = "l2"
    robust_scale: float = 0.05
    translation_smoothness: float = 100.0
    size_prior: bool = True
    size_spread: float = 0.1
    noise_fit: bool = True
    noise_spread: bool = True
    bone_weight: float = 0.0
    symmetry_weight: float = 0.0
    depth_smoothness: float = 10.0
    floor: tuple[float, float, float, float] | None = None
    floor_weight: float = 1.0
    contact_weight: float = 0.1
    slide_weight: float = 1.0
    support_spread: float = 0.03
    solver: str = "ddim"
    temperature: float = 1.0
    seed: int = 0

    def __post_init__(self) -> None:
        numbers = {k: v for k, v in vars(self).items() if isinstance(v, float)}
        checks = [
            *(
                (math.isfinite(v), f"{k.replace('_', ' ')} must be a finite number, got {v}")
                for k, v in numbers.items()
            ),
            (self.samples >= 1, f"samples must be at least 1, got {self.samples}"),
            (self.samples <= MAX_SAMPLES, f"samples must be at most {MAX_SAMPLES}, got {self.samples}"),
            (0 <= self.seed < 2**63, f"seed must be in 0..2**63-1, got {self.seed}"),
            (1 <= self.steps <= 50, f"steps must be in 1..50, got {self.steps}"),
            (0 <= self.skip < self.steps, f"skip must be in 0..{self.steps - 1}, got {self.skip}"),
            (0 <= self.eta <= 1, f"eta must be in [0, 1], got {self.eta}"),
            (self.guidance_iters >= 0, f"guidance iterations must be >= 0, got {self.guidance_iters}"),
            (self.guidance_tol >= 0, f"guidance tolerance must be >= 0, got {self.guidance_tol}"),
            (self.energy_scale > 0, f"energy scale must be positive, got {self.energy_scale}"),
            (0 < self.decay < 1, f"decay must be in (0, 1), got {self.decay}"),
            (self.grow >= 1, f"grow must be >= 1, got {self.grow}"),
            (self.direction in DIRECTIONS, f"unknown direction {self.direction!r}; choose {', '.join(DIRECTIONS)}"),
            (self.damping > 0, f"damping must be positive, got {self.damping}"),
            (self.step_rule in STEP_RULES, f"unknown step rule {self.step_rule!r}; choose {', '.join(STEP_RULES)}"),
            (self.robust in ROBUST_LOSSES, f"unknown robust loss {self.robust!r}; choose {', '.join(ROBUST_LOSSES)}"),
            (self.robust_scale > 0, f"robust scale must be positive, got {self.robust_scale}"),
            (self.translation_smoothness >= 0, "translation smoothness must be >= 0"),
            (0 <= self.size_spread <= 0.5, f"size spread must be in [0, 0.5], got {self.size_spread}"),
            (self.bone_weight >= 0 and self.symmetry_weight >= 0, "structural energy weights must be >= 0"),
            (self.depth_smoothness >= 0, f"depth smoothness must be >= 0, got {self.depth_smoothness}"),
            (self.floor is None or len(self.floor) == 4, f"floor must be (nx, ny, nz, d), got {self.floor}"),
            (min(self.floor_weight, self.contact_weight, self.slide_weight) >= 0, "floor weights must be >= 0"),
            (0 <= self.support_spread <= 0.2, f"support spread must be in [0, 0.2] m, got {self.support_spread}"),
            (self.solver in SOLVERS, f"unknown solver {self.solver!r}; choose {', '.join(SOLVERS)}"),
            (self.solver == "ddim" or self.eta == 0, "the dpm2m solver is deterministic: eta must be 0"),
            (0 < self.temperature <= 2, f"temperature must be in (0, 2], got {self.temperature}"),
        ]
        for ok, message in checks:
            if not ok:
                raise ValueError(message)
