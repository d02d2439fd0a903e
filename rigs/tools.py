"""Third-party programs a test runs (a real VCD reader): skipped with the reason where
they are missing - except on CI, where ``.ci/run`` installs them, so a missing one
fails the test instead of hiding it."""

from __future__ import annotations

import os
import shutil


def need_tools(*names: str, package: str) -> None:
    import pytest

    missing = [n for n in names if shutil.which(n) is None]
    if not missing:
        return
    if os.environ.get("CI"):
        pytest.fail(f"CI: {', '.join(missing)} missing (apt package {package}; .ci/run "
                    "installs it)")
    pytest.skip(f"{', '.join(missing)} not installed (apt package {package})")
