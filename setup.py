"""The compiled kernel, frcontrol._kernel (everything else is declared in pyproject.toml).

Plain C against the CPython API: the build needs only setuptools (pyproject's build-system
requires), a C compiler and Python's headers. ``optional=True``: where no compiler is found the
package still installs and runs on the NumPy path (frcontrol/kernel.py); CI's tests fail then.
"""

from setuptools import Extension, setup

setup(ext_modules=[Extension("frcontrol._kernel", sources=["frcontrol/_kernel.c"], optional=True)])
