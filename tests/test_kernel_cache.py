"""Cached kernels are stamped with the whole package's source (granwave.kernel_cache): a change to
any module recompiles them, not only a change to the kernel's own file."""

from __future__ import annotations

import re
from pathlib import Path

from granwave import kernel_cache
from granwave.dem import kernels, mean_flow, pulse_kernels

PACKAGE = Path(kernel_cache.PACKAGE_DIR)


def _locator(dispatcher):
    return dispatcher._cache._impl.locator


def test_granwave_kernels_use_the_package_stamp():
    for f in (kernels.run_chunk, mean_flow.slab_means, pulse_kernels.pulse_samples):
        loc = _locator(f)
        assert type(loc) in kernel_cache.LOCATORS
        stamp = loc.get_source_stamp()
        assert stamp[1] == kernel_cache.source_hash()


def test_other_functions_keep_numba_locators(tmp_path):
    src = tmp_path / "outside.py"
    src.write_text("import numba\n\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1\n")
    import importlib.util

    spec = importlib.util.spec_from_file_location("outside_granwave", src)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.f(1) == 2
    assert type(_locator(mod.f)) not in kernel_cache.LOCATORS


def test_source_hash_follows_every_file(tmp_path):
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    (tmp_path / "sub" / "__pycache__").mkdir()
    first = kernel_cache.source_hash.__wrapped__(str(tmp_path))
    (tmp_path / "sub" / "__pycache__" / "c.py").write_text("ignored\n")
    (tmp_path / "notes.txt").write_text("not source\n")
    assert kernel_cache.source_hash.__wrapped__(str(tmp_path)) == first
    (tmp_path / "sub" / "b.py").write_text("y = 3\n")  # a helper in another module changes
    assert kernel_cache.source_hash.__wrapped__(str(tmp_path)) != first


def test_install_is_idempotent():
    assert kernel_cache.install() and kernel_cache.install()
    classes = kernel_cache._IMPL._locator_classes
    assert classes[: len(kernel_cache.LOCATORS)] == list(kernel_cache.LOCATORS)
    assert sum(c in kernel_cache.LOCATORS for c in classes) == len(kernel_cache.LOCATORS)


def test_every_module_with_cached_kernels_imports_the_stamp():
    """A module with njit(cache=True) that did not import kernel_cache before its kernels could
    be stamped per file again if it were imported first."""
    missing = []
    for path in PACKAGE.rglob("*.py"):
        text = path.read_text()
        if re.search(r"cache\s*=\s*True", text) and path.name != "kernel_cache.py":
            if not re.search(r"^from \.+ import kernel_cache\b", text, re.M):
                missing.append(str(path.relative_to(PACKAGE)))
    assert missing == []
