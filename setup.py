"""Builds the Python module trompo for `pip install .` (pyproject.toml): the extension
trompo._trompo from python/trompo_module.cpp and the CLI's engine tools/simulate/simulate_core.cpp
and command line tools/simulate/flags.cpp (CLI11) (header-only C++20: Eigen 3.4, and Boost.Math
for the closed forms when its headers are found), and python/trompo/__init__.py with the
interpreter it was built for filled in (as CMake's configure_file does)."""
import os
import sys

from pybind11.setup_helpers import Pybind11Extension, build_ext
from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))


def first_dir(*candidates):
    return next((d for d in candidates if os.path.isdir(d)), None)


eigen = first_dir(os.environ.get("EIGEN3_INCLUDE_DIR", ""), "/usr/include/eigen3", "/usr/local/include/eigen3")
if eigen is None:
    sys.exit("trompo: Eigen 3.4 headers not found (set EIGEN3_INCLUDE_DIR)")
macros = [("TROMPO_VERSION", '"0.1.0"')]
if os.path.isfile("/usr/include/boost/math/special_functions/ellint_rf.hpp"):
    macros.append(("TROMPO_HAVE_EXACT", "1"))

# The module and the CLI's engine (tools/simulate/simulate_core.cpp), as CMake builds it.
# TROMPO_ENGINE_LIB names an engine CMake has already compiled (the static library
# trompo_simulate_core, position-independent): it is linked instead of compiled again. The
# test command's pip-install check does so; a plain `pip install .` compiles the engine.
sources = [os.path.join("python", "trompo_module.cpp")]
engine_lib = os.environ.get("TROMPO_ENGINE_LIB", "")
if engine_lib:
    if not os.path.isfile(engine_lib):
        sys.exit("trompo: TROMPO_ENGINE_LIB=%s: no such file" % engine_lib)
else:
    # the command line (flags.cpp) is declared with CLI11 (Debian: libcli11-dev, header-only)
    cli11 = first_dir(os.environ.get("CLI11_INCLUDE_DIR", ""), "/usr/include", "/usr/local/include")
    if not os.path.isfile(os.path.join(cli11 or "", "CLI", "CLI.hpp")):
        sys.exit("trompo: CLI11 headers (CLI/CLI.hpp) not found: apt-get install libcli11-dev, or set CLI11_INCLUDE_DIR")
    sources += [os.path.join("tools", "simulate", f) for f in ("simulate_core.cpp", "flags.cpp")]

ext = Pybind11Extension(
    "trompo._trompo",
    sources,
    extra_objects=[engine_lib] if engine_lib else [],
    include_dirs=[os.path.join(HERE, "include"), os.path.join(HERE, "tools"), eigen] + ([cli11] if not engine_lib else []),
    define_macros=macros,
    cxx_std=20,
    # TROMPO_CXXFLAGS replaces the optimisation flags (the test command's pip-install check
    # builds with -O0: it checks that the package builds, imports and runs, not its speed)
    extra_compile_args=os.environ.get("TROMPO_CXXFLAGS", "-O2").split(),
)


class BuildPy(build_py):
    """Copies python/trompo with @Python3_EXECUTABLE@ replaced by this interpreter."""

    def run(self):
        super().run()
        target = os.path.join(self.build_lib, "trompo", "__init__.py")
        with open(target) as f:
            text = f.read()
        with open(target, "w") as f:
            f.write(text.replace("@Python3_EXECUTABLE@", sys.executable))


setup(
    packages=["trompo"],
    package_dir={"": "python"},
    ext_modules=[ext],
    cmdclass={"build_ext": build_ext, "build_py": BuildPy},
    zip_safe=False,
)
