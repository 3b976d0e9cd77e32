"""Package discovery; everything else is in pyproject.toml.

The source tree keeps cli/, bench/, glsl/ and scenes/ beside mcpt/, and the wheel maps them into
the one mcpt namespace (cli/ -> mcpt.cli, ...). setuptools' ``packages.find`` cannot prefix what it
finds in a mapped folder, so the packages are found here: a new subpackage in any of these folders
ships without editing a list.
"""

from setuptools import find_packages, setup

MAPPED = {"mcpt.cli": "cli", "mcpt.bench": "bench", "mcpt.glsl": "glsl", "mcpt.scenes": "scenes"}

packages = find_packages(include=["mcpt", "mcpt.*"])
for name, folder in MAPPED.items():
    packages += [name] + [f"{name}.{sub}" for sub in find_packages(where=folder)]

setup(packages=packages, package_dir=MAPPED)
