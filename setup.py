"""Packaging beyond what pyproject.toml's [tool.setuptools] table can say: the device
firmware's sources (``firmware/``, a folder of the checkout beside the packages) are
installed as the package data of ``fas.device.firmware``, so that ``stepperdemo device
--simavr`` can build them after ``pip install`` (fas.device.simavr.firmware_dir).

The packages are found as namespace packages: ``fas/quickstep`` has no
``__init__.py`` and a plain ``find_packages()`` would leave it out.
"""

from setuptools import find_namespace_packages, setup

PACKAGES = find_namespace_packages(include=["fas", "fas.*", "stepperdemo", "stepperdemo.*"],
                                   exclude=["*.__pycache__"])
FIRMWARE = "fas.device.firmware"
FIRMWARE_DATA = {  # the folders of firmware/ and what they hold
    FIRMWARE: ["Makefile", "*.c", "*.h", "*.md", "*.ini", "*.ino"],
    f"{FIRMWARE}.simavr": ["*.c"],  # the simavr harness
    f"{FIRMWARE}.tests": ["*.c"],  # the step generator's test rig
}

setup(packages=[*PACKAGES, *FIRMWARE_DATA], package_dir={FIRMWARE: "firmware"},
      package_data=FIRMWARE_DATA)
