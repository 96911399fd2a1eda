"""``--sync auto|none|offsets.json``: the option's help and the file ``lift --sync auto`` writes for reuse.

What each choice does is :mod:`platypose.lifting.sync_choice` (shared with ``platypose.lift(sync=...)``).
"""

from __future__ import annotations

import json
from pathlib import Path

from platypose.lifting.atomic import write_text_atomic
from platypose.lifting.sync_choice import Synced

SYNC_HELP = (
    "Camera synchronisation: auto (estimate each view's time offset from the keypoints' motion, "
    "refined by reprojection), none (use the calibration's time_offset_s), or an offsets.json "
    '({"cam01": 0.0, "cam02": 0.12}, seconds to add to each view\'s frame times).'
)


def write_offsets(path: Path, synced: Synced) -> None:
    """Write the cameras' offsets (and their confidence when estimated) as JSON that ``--sync`` reads back."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, json.dumps(synced.record(), indent=1) + "\n")
