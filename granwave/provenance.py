"""What every output file records about how it was made."""

from __future__ import annotations

import functools
import subprocess
import sys
from pathlib import Path

from . import __version__


@functools.lru_cache(maxsize=1)
def git_revision() -> str:
    """The git revision of the granwave source tree, or 'unknown' outside a checkout."""
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(
            ["git", "-C", str(here), "rev-parse", "--short=12", "HEAD"],
            capture_output=True, text=True, timeout=5, check=True,
        )
        dirty = subprocess.run(
            ["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True, text=True, timeout=5, check=True,
        )
        return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def provenance_attrs() -> dict:
    """Attributes written on the root of every granwave file."""
    return {
        "granwave_version": __version__,
        "git_revision": git_revision(),
        "command_line": " ".join(sys.argv),
    }
