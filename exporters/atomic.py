"""Atomic writes live in ``lifting.atomic``; this name stays while ``platypose_cli/lift_*`` import it from here."""

from lifting.atomic import atomic_path, write_text_atomic

__all__ = ["atomic_path", "write_text_atomic"]
