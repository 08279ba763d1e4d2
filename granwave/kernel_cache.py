"""numba's on-disk cache of granwave's kernels, stamped with the whole package's source.

numba stamps a cached kernel with the source of its own file only. granwave's kernels inline
helpers from other modules (the contact law of ``contact.py`` and ``dem/pair_tile.py``, the
mean-flow damping of ``dem/mean_flow.py``, ``geometry.py``), so after a change to such a
helper alone (an editable install updated by ``git pull``, a local edit) a kernel would load
machine code built with the old helper: other physics, without a word. Seen in this project:
an edit of ``dem/mean_flow.py`` left ``dem/kernels.py``'s cached kernels running the old
rule until ``__pycache__`` was deleted.

Importing this module (every module with cached kernels does, before its first kernel) puts
locators in front of numba's own for granwave's files only: the same places as numba's
(``NUMBA_CACHE_DIR`` when set, else the in-tree ``__pycache__``, else the user-wide cache), with
a stamp that also holds a hash of every ``.py`` file of the package. Any change to the package
then recompiles its kernels once (numba rewrites an entry whose stamp differs, so old entries
do not pile up); functions outside granwave keep numba's locators unchanged.
"""

from __future__ import annotations

import functools
import hashlib
import os
import warnings

from numba.core import caching

#: The package directory whose sources stamp the cached kernels.
PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))


@functools.lru_cache(maxsize=None)
def source_hash(root: str = PACKAGE_DIR) -> str:
    """SHA-256 over the relative path and contents of every ``.py`` file under ``root``, in
    sorted order (``__pycache__`` skipped): about 1 MB read once per process."""
    h = hashlib.sha256()
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                h.update(os.path.relpath(path, root).encode())
                h.update(b"\0")
                with open(path, "rb") as f:
                    h.update(f.read())
    return h.hexdigest()


def _in_package(py_file: str) -> bool:
    return os.path.abspath(py_file).startswith(PACKAGE_DIR + os.sep)


def _stamped(base):
    """``base`` (a numba locator class) for granwave's files, with the package's hash in the stamp."""

    class PackageStamped(base):
        def get_source_stamp(self):
            return (super().get_source_stamp(), source_hash())

        @classmethod
        def from_function(cls, py_func, py_file):
            if not _in_package(py_file):
                return None
            return super().from_function(py_func, py_file)

    PackageStamped.__name__ = PackageStamped.__qualname__ = f"PackageStamped{base.__name__}"
    return PackageStamped


def _numba_class(name: str):
    """A class of numba's caching module by its public name or its name before numba made it
    public (a leading underscore); None when neither exists."""
    return getattr(caching, name, None) or getattr(caching, "_" + name, None)


_BASES = tuple(_numba_class(name) for name in ("UserProvidedCacheLocator", "InTreeCacheLocator",
                                               "UserWideCacheLocator"))
_IMPL = _numba_class("CacheImpl")
#: numba's file-backed locators, in numba's order of preference, stamped with the package
LOCATORS = tuple(_stamped(base) for base in _BASES) if all(_BASES) else ()


def install() -> bool:
    """Put :data:`LOCATORS` first in numba's list (idempotent; the list is a class attribute of
    numba's cache implementation, used by the CPU kernels' caches). Returns False, with a
    warning, where this numba has not the classes it needs."""
    classes = getattr(_IMPL, "_locator_classes", None)
    if not LOCATORS or not isinstance(classes, list):
        warnings.warn("granwave: this numba's cache has no locator list; kernels are cached per file "
                      "(after an update of granwave, delete its __pycache__ folders)", RuntimeWarning)
        return False
    if classes[: len(LOCATORS)] != list(LOCATORS):
        classes[:0] = LOCATORS
    return True


install()
