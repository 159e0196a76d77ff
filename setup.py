"""The build step of `pip install .` (pyproject.toml): configures the CMake project with only
what the extension module needs (no tests, benchmarks, firmware or browser page), builds the
target scaratwin_python for the interpreter that runs pip, and puts the module, the generated
_paths.py (the pip layout) and the robot descriptions into the package."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = Path(self.build_temp).resolve() / "cmake"
        configure = ["cmake", "-S", str(ROOT), "-B", str(build),
                     "-DCMAKE_BUILD_TYPE=Release", "-DSCARATWIN_PYTHON=ON",
                     "-DSCARATWIN_BUILD_TESTS=OFF", "-DSCARATWIN_BUILD_BENCH=OFF",
                     "-DSCARATWIN_BUILD_FIRMWARE=OFF", "-DSCARATWIN_NPM=SCARATWIN_NPM-NOTFOUND",
                     f"-DPython3_EXECUTABLE={sys.executable}"]
        if shutil.which("ninja"):
            configure += ["-G", "Ninja"]
        subprocess.run(configure, check=True)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", "2")
        subprocess.run(["cmake", "--build", str(build), "--target", "scaratwin_python",
                        "-j", jobs], check=True)
        module = Path(self.get_ext_fullpath(ext.name))
        module.parent.mkdir(parents=True, exist_ok=True)
        built = next((build / "python" / "scaratwin").glob("_core*.so"))
        shutil.copy2(built, module)
        shutil.copy2(build / "python" / "wheel" / "_paths.py", module.parent / "_paths.py")
        data = module.parent / "data" / "config"
        data.mkdir(parents=True, exist_ok=True)
        for toml in (ROOT / "config").glob("*.toml"):
            shutil.copy2(toml, data / toml.name)


setup(ext_modules=[Extension("scaratwin._core", sources=[])], cmdclass={"build_ext": CMakeBuild})
