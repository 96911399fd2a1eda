"""The settings of a lift: the sampler, the windows, the prior to load, and how one take is lifted."""

from __future__ import annotations

import dataclasses
import numbers
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from platypose.lifting.errors import InputError
from platypose.lifting.settings.choices import FloorChoice, check_sync, parse_persons, read_floor
from platypose.lifting.settings.fields import check_types, choose, require, setting

ROBUST_LOSSES = ("l2", "geman-mcclure")
STEP_RULES = ("backtrack", "paper")
DIRECTIONS = ("gauss-newton", "gradient")
SOLVERS = ("ddim", "dpm2m")
MAX_SAMPLES = 5000  # hypotheses per person: beyond this the arrays outgrow any machine for a minute of video
DEVICES = ("cpu", "cuda", "auto")
RUNTIMES = ("auto", "float32", "bfloat16", "onnx")
ROOT_MODES = ("auto", "triangulate", "solve")

MAX_GAP_S = 24 * 3600.0  # a person unseen for longer than a day is not one motion lifted through its gap
MAX_SAMPLER_VALUE = 1e6  # any number of the sampler's settings; float32 squares stay finite under 3.4e38


@dataclass(frozen=True)
class SamplerConfig:
    """Every knob of the sampler; defaults follow the paper (T=10, S=2, k=10) except where noted.

    Each field's help says what it does; the longer story of the guidance, placement, floor and
    noise options is in the modules that use them (:mod:`platypose.lifting.sampling.guidance`,
    :mod:`platypose.lifting.sampling.views`, :mod:`platypose.lifting.sampling.grounding`), and what they trade is in docs/prior.md.
    """

    samples: int = setting(50, "Hypotheses per person.", option=True)
    steps: int = setting(10, "Diffusion steps kept, of the prior's 50 (T).", option=True)
    skip: int = setting(2, "Noisiest kept steps skipped (S).", option=True)
    eta: float = setting(0.0, "DDIM eta: 0 deterministic re-noising, 1 fresh noise.", option=True)
    guidance_iters: int = setting(10, "Guidance steps per diffusion step, at most (k).", option=True, also=("k",))
    guidance_tol: float = setting(1e-3, "Guidance stops once every hypothesis gains less than this share.")
    energy_scale: float = setting(1.0, "Initial guidance step (lambda).", option=True, also=("lambda",))
    decay: float = setting(0.1, "Factor cutting the guidance step when a step fails.")
    grow: float = setting(2.0, "Factor growing the guidance step after an accepted one (backtrack).")
    step_rule: str = setting("backtrack", "backtrack (reject steps raising the energy) or paper (keep every step).")
    direction: str = setting("gauss-newton", "Guidance direction: gauss-newton or gradient.")
    damping: float = setting(0.1, "Gauss-Newton damping.")
    robust: str = setting("l2", "Reprojection loss: l2 or geman-mcclure.", option=True, panel="Experimental")
    robust_scale: float = setting(0.05, "Scale of the robust loss (normalised image units).")
    translation_smoothness: float = setting(100.0, "Coupling of per-frame root offsets (0: independent frames).")
    size_prior: bool = setting(True, "Place each prediction as a person of adult size.", option=True)
    size_spread: float = setting(0.1, "Log-normal spread of the hypotheses' sizes (0: all typical).", option=True)
    noise_fit: bool = setting(True, "Follow the 2D only as far as its jitter allows.", option=True)
    noise_spread: bool = setting(True, "2+ views: spread hypotheses by the 2D noise.", option=True)
    bone_weight: float = setting(0.0, "Constant bone lengths over time (0: off).", option=True, panel="Experimental")
    symmetry_weight: float = setting(0.0, "Left/right bone symmetry (0: off).", option=True, panel="Experimental")
    limit_weight: float = setting(0.0, "Joint limits: knees bent back, the neck past 70 degrees (0: off).", option=True)
    depth_smoothness: float = setting(10.0, "One view: smoothness of every joint's depth path (0: off).", option=True)
    floor: tuple[float, float, float, float] | None = setting(None, "Floor plane (nx, ny, nz, d); None: no floor.")
    floor_weight: float = setting(1.0, "Weight per squared metre of a joint below the floor.")
    contact_weight: float = setting(0.1, "Weight holding stance ankles on the floor.")
    slide_weight: float = setting(1.0, "Weight against stance ankles sliding along the floor.")
    support_spread: float = setting(0.03, "Spread (m) of the stance ankles' heights above the floor.")
    solver: str = setting(
        "ddim", "Re-noising between network calls: ddim or dpm2m (DPM-Solver++(2M)).", option=True, panel="Experimental"
    )
    temperature: float = setting(
        1.0, "Scale of the initial noise (1: the prior as trained).", option=True, panel="Experimental"
    )
    seed: int = setting(0, "Random seed of the sampler.", option=True)

    def __post_init__(self) -> None:
        check_types(self)
        for f in dataclasses.fields(self):  # the sampler computes in float32: products of two stay finite
            value = getattr(self, f.name)
            if isinstance(value, float) and abs(value) > MAX_SAMPLER_VALUE:
                raise InputError(
                    f"{f.name} must be between {-MAX_SAMPLER_VALUE:,.0f} and {MAX_SAMPLER_VALUE:,.0f}, got {float(value)!r}",
                    option=f.name,
                )
        require(
            [
                (self.samples >= 1, "samples", f"samples must be at least 1, got {self.samples}"),
                (self.samples <= MAX_SAMPLES, "samples", f"samples must be at most {MAX_SAMPLES}, got {self.samples}"),
                (0 <= self.seed < 2**63, "seed", f"seed must be in 0..2**63-1, got {self.seed}"),
                (1 <= self.steps <= 50, "steps", f"steps must be in 1..50, got {self.steps}"),
                (0 <= self.skip < self.steps, "skip", f"skip must be in 0..{self.steps - 1}, got {self.skip}"),
                (0 <= self.eta <= 1, "eta", f"eta must be in [0, 1], got {self.eta}"),
                (self.guidance_iters >= 0, "guidance_iters", f"guidance_iters must be >= 0, got {self.guidance_iters}"),
                (self.guidance_tol >= 0, "guidance_tol", f"guidance_tol must be >= 0, got {self.guidance_tol}"),
                (self.energy_scale > 0, "energy_scale", f"energy_scale must be positive, got {self.energy_scale}"),
                (0 < self.decay < 1, "decay", f"decay must be in (0, 1), got {self.decay}"),
                (self.grow >= 1, "grow", f"grow must be >= 1, got {self.grow}"),
                (self.direction in DIRECTIONS, "direction", choose("direction", self.direction, DIRECTIONS)),
                (self.damping > 0, "damping", f"damping must be positive, got {self.damping}"),
                (self.step_rule in STEP_RULES, "step_rule", choose("step_rule", self.step_rule, STEP_RULES)),
                (self.robust in ROBUST_LOSSES, "robust", choose("robust", self.robust, ROBUST_LOSSES)),
                (self.robust_scale > 0, "robust_scale", f"robust_scale must be positive, got {self.robust_scale}"),
                (self.translation_smoothness >= 0, "translation_smoothness", "translation_smoothness must be >= 0"),
                (
                    0 <= self.size_spread <= 0.5,
                    "size_spread",
                    f"size_spread must be in [0, 0.5], got {self.size_spread}",
                ),
                (self.bone_weight >= 0, "bone_weight", f"bone_weight must be >= 0, got {self.bone_weight}"),
                (
                    self.symmetry_weight >= 0,
                    "symmetry_weight",
                    f"symmetry_weight must be >= 0, got {self.symmetry_weight}",
                ),
                (self.limit_weight >= 0, "limit_weight", f"limit_weight must be >= 0, got {self.limit_weight}"),
                (self.depth_smoothness >= 0, "depth_smoothness", "depth_smoothness must be >= 0"),
                (
                    min(self.floor_weight, self.contact_weight, self.slide_weight) >= 0,
                    "floor_weight",
                    "floor weights must be >= 0",
                ),
                (0 <= self.support_spread <= 0.2, "support_spread", "support_spread must be in [0, 0.2] m"),
                (self.solver in SOLVERS, "solver", choose("solver", self.solver, SOLVERS)),
                (self.solver == "ddim" or self.eta == 0, "eta", "the dpm2m solver is deterministic: eta must be 0"),
                (0 < self.temperature <= 2, "temperature", f"temperature must be in (0, 2], got {self.temperature}"),
            ]
        )


@dataclass(frozen=True)
class WindowSettings:
    """How a track is cut into windows of the prior: their length, overlap and the weight of the overlap anchors."""

    window: int = setting(64, "Window length in prior frames (capped by the prior).", option=True)
    overlap: int = setting(16, "Frames shared by consecutive windows.", option=True)
    anchor_weight: float = setting(100.0, "Weight holding a window's overlap on the window before.")
    max_gap: float = setting(
        5.0,
        "Seconds a person may go unseen and still be lifted through as one motion (the prior fills the gap).",
        option=True,
    )

    def __post_init__(self) -> None:
        check_types(self)
        require(
            [
                (self.window >= 2, "window", f"window must be >= 2, got {self.window}"),
                (
                    0 <= self.overlap <= self.window // 2,
                    "overlap",
                    f"overlap must be in 0..window/2, got {self.overlap}",
                ),
                (self.anchor_weight >= 0, "anchor_weight", f"anchor_weight must be >= 0, got {self.anchor_weight}"),
                (
                    0 <= self.max_gap <= MAX_GAP_S,
                    "max_gap",
                    f"max_gap must be a number of seconds from 0 to {MAX_GAP_S:.0f} (a day), got {self.max_gap!r}",
                ),
            ]
        )


@dataclass(frozen=True)
class PriorSettings:
    """Which prior, on which device, run by which runtime (:func:`platypose.lifting.prior.runtime.load_settings` loads it)."""

    path: Path | None = setting(None, "Motion prior checkpoint (default: the shipped one).", option=True)
    device: str = setting("cpu", "Sampler device: cpu, cuda or auto (cuda when available).", option=True)
    runtime: str = setting(
        "auto",
        "Denoiser runtime: auto (bfloat16 where this CPU runs it fast, else float32), float32, bfloat16 or onnx.",
        option=True,
    )

    def __post_init__(self) -> None:
        check_types(self)
        require(
            [
                (self.device in DEVICES, "device", choose("device", self.device, DEVICES)),
                (self.runtime in RUNTIMES, "runtime", choose("runtime", self.runtime, RUNTIMES)),
            ]
        )


@dataclass(frozen=True)
class TakeSettings:
    """How one take is lifted besides its inputs and prior: who, their roots, the floor, the clock, the sampler.

    Natural Python values are accepted and stored in the command's spelling: ``persons`` 2 as "largest:2", ``floor``
    None as "none" and four numbers as "nx,ny,nz,d", ``sync`` None as "none".
    """

    persons: str = setting(
        "all", "Who to lift: all, largest, largest:N (the N largest), ids id:0,2 (or 0,2; one id: id:2 or 2,), or @X,Y."
    )
    root: str = setting("auto", "Root path: auto (triangulated with 2+ views, else solved), triangulate, solve.")
    root_trajectory: Path | None = setting(None, "Known pelvis path: npz (frame_times, root) or CSV (time,x,y,z).")
    floor: str = setting(
        "auto",
        "auto (the calibration's z = 0; without one, one camera: estimated under a quick lift), z=H, "
        "nx,ny,nz,d (the plane n.x + d = 0), or none. Grounds every hypothesis (docs/lift.md).",
    )
    sync: object = setting(
        "none",
        "Camera synchronisation: auto (estimate each view's time offset from the keypoints' motion, "
        "refined by reprojection), none (use the calibration's time_offset_s), or an offsets.json "
        '({"cam01": 0.0, "cam02": 0.12}, seconds to add to each view\'s frame times).',
    )
    sampler: SamplerConfig = setting(SamplerConfig(), "The sampler's settings.")
    windows: WindowSettings = setting(WindowSettings(), "How tracks are cut into windows.")

    def __post_init__(self) -> None:
        persons, floor, sync = self.persons, self.floor, self.sync
        if isinstance(persons, numbers.Integral) and not isinstance(persons, bool):
            persons = f"largest:{persons}" if persons > 0 else persons
        if floor is None:
            floor = "none"
        elif isinstance(floor, (tuple, list)) and any(isinstance(v, bool) for v in floor):
            raise InputError(f"floor must be auto, none, z=H or four numbers nx,ny,nz,d; got {floor!r}", option="floor")
        elif isinstance(floor, (tuple, list)) and all(isinstance(v, numbers.Real) for v in floor):
            floor = ",".join(repr(float(v)) for v in floor)
        sync = "none" if sync is None else str(sync) if isinstance(sync, os.PathLike) else sync
        for name, value in (("persons", persons), ("floor", floor), ("sync", sync)):
            object.__setattr__(self, name, value)
        check_types(self)
        require([(self.root in ROOT_MODES, "root", f"root must be one of {', '.join(ROOT_MODES)}, got {self.root!r}")])
        object.__setattr__(self, "_floor_choice", read_floor(self.floor))  # parsed once, here
        if isinstance(self.sync, Mapping):
            object.__setattr__(self, "sync", dict(self.sync))
        elif not isinstance(self.sync, str):
            raise InputError(f"sync must be auto, none, an offsets file or a mapping, got {self.sync!r}", option="sync")
        check_sync(self.sync)
        for name, cls in (("sampler", SamplerConfig), ("windows", WindowSettings)):
            if not isinstance(getattr(self, name), cls):
                raise InputError(f"{name} must be a {cls.__name__}, got {getattr(self, name)!r}", option=name)
        parse_persons(self.persons)  # InputError for a choice the detectors cannot read

    @property
    def floor_choice(self) -> FloorChoice:
        """The floor ``floor`` names, as :func:`platypose.lifting.settings.choices.read_floor` read it when these
        settings were made: a plane given, "auto" or None (:func:`platypose.lifting.floor.floor_for_lift` makes it
        the lift's floor)."""
        return self._floor_choice
