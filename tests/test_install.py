"""The installed package is the one imported, whatever folders sit in the working directory."""

import subprocess
import sys


def test_a_folder_named_granwave_does_not_shadow_the_package(tmp_path):
    # e.g. the clone itself seen from its parent folder, or a results folder of that name
    (tmp_path / "granwave").mkdir()
    run = subprocess.run([sys.executable, "-c", "import granwave; print(granwave.__version__)"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    import granwave

    assert run.stdout.strip() == granwave.__version__
