"""Builds the Python module `autonomsim` with CMake for the interpreter that runs pip.

    python3 -m venv --system-site-packages VENV
    VENV/bin/pip install --no-build-isolation --no-index .

The extension (`autonomsim._core`) is CMake's target autonomsim_pymodule, built in build-python/
(a build folder of its own, release flags, no benchmarks); the pure Python layer is python/autonomsim.
See docs/python.md.
"""

import os
import pathlib
import re
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parent


def project_version() -> str:
    text = (ROOT / "CMakeLists.txt").read_text()
    return re.search(r"project\(autonomsim VERSION ([\d.]+)", text).group(1)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = ROOT / "build-python"
        generator = ["-G", "Ninja"] if shutil.which("ninja") else []
        subprocess.check_call(["cmake", "-S", str(ROOT), "-B", str(build), *generator,
                               "-DCMAKE_BUILD_TYPE=RelWithDebInfo", "-DCMAKE_UNITY_BUILD=ON",
                               "-DAUTONOMSIM_BUILD_BENCH=0", "-DAUTONOMSIM_DEBUG_LINES_ONLY=1",
                               f"-DPython3_EXECUTABLE={sys.executable}"])
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 1))
        subprocess.check_call(["cmake", "--build", str(build), "--target", "autonomsim_pymodule",
                               "-j", jobs])
        built = next((build / "python" / "autonomsim").glob("_core*.so"))
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, target)


setup(
    name="autonomsim",
    version=project_version(),
    description="Discrete-event closed-loop simulator of the AutonomROS model-car fleet",
    packages=["autonomsim"],
    package_dir={"": "python"},
    package_data={"autonomsim": ["__init__.pyi", "py.typed"]},
    ext_modules=[Extension("autonomsim._core", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    python_requires=">=3.9",
    install_requires=["numpy"],
    zip_safe=False,
    # setuptools' own folders beside CMake's, not in the CMake build folder build/
    options={"build": {"build_base": "build-python/setuptools"}},
)
