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


#: Root attributes that describe a file itself (written by every writer; never copied
#: from an input file's attributes into an output's).
FILE_ATTRS = ("schema", "schema_version", "granwave_version", "git_revision", "command_line")

#: Attributes that identify a sample: every stage carries them from its input to its output
#: (each stage adds the few of its own that later stages need).
SAMPLE_ATTRS = ("pressure", "seed", "friction", "kind", "dim", "poisson")


def carried(attrs: dict, keys=SAMPLE_ATTRS) -> dict:
    """The entries of ``attrs`` named in ``keys`` (those present), in the order of ``keys``."""
    return {k: attrs[k] for k in keys if k in attrs}


def provenance_attrs() -> dict:
    """Attributes written on the root of every granwave file."""
    return {
        "granwave_version": __version__,
        "git_revision": git_revision(),
        "command_line": " ".join(sys.argv),
    }
