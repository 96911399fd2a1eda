"""The limits past which a person's lift is flagged (:mod:`lifting.checks.plausibility` measures, :mod:`lifting.checks.flags`
says), in one place for both."""

UNDER_FLOOR = 0.03  # metres below the floor
UNDER_SHARE = 0.01  # share of hypothesis-frames
SLIDE = 0.02  # metres per frame
SPREAD = 1.0  # metres
SUPPORT_STEP = 0.15  # metres: the support changes level where it moves this far from the level's running mean
MIN_LEVEL = 0.5  # seconds: a level held shorter is not reported (steps, landings)
ON_FLOOR = SUPPORT_STEP  # metres: a level nearer the floor than a change of level (a stair) is the floor
