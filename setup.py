"""The compiled kernel, frcontrol._kernel (everything else is declared in pyproject.toml).

Plain C against the CPython API: the build needs only setuptools (pyproject's build-system
requires), a C compiler and Python's headers; the extension records its source's SHA-256.
``optional=True``: where no compiler is found the
package still installs and runs on the NumPy path (frcontrol/kernel.py); CI's tests fail then.
"""

import hashlib
from pathlib import Path

from setuptools import Extension, setup

SOURCE = "frcontrol/_kernel.c"
# The source's SHA-256 is compiled in (frcontrol._kernel.SOURCE_SHA256): an editable install whose
# _kernel.c changed since the build is then told apart from a current one (frcontrol/kernel.py).
DIGEST = hashlib.sha256((Path(__file__).parent / SOURCE).read_bytes()).hexdigest()

setup(ext_modules=[Extension("frcontrol._kernel", sources=[SOURCE], optional=True,
                             define_macros=[("FRC_KERNEL_SOURCE_SHA256", f'"{DIGEST}"')])])
