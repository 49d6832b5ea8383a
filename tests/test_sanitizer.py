"""The compiled kernel under AddressSanitizer and UndefinedBehaviorSanitizer.

The extension is built again from this checkout's frcontrol/_kernel.c with
``-fsanitize=address,undefined`` into a temporary copy of the package, and the kernel's tests (its
own, the contact rows', and the cross-checks of every compiled function against its NumPy twin:
tests/test_kernel.py's CROSS_CHECKS) run in a subprocess that imports that copy, with the ASan
runtime preloaded (CPython itself is not instrumented; the C++ runtime with it, for Pinocchio's
exceptions). Leak detection is off: CPython keeps
objects alive until exit by design. Any sanitizer report (an out-of-bounds access, a
use-after-free, an overflow, a misaligned load) aborts the run, and the test fails with it.

Outside CI (env CI unset) it skips: it needs gcc and its sanitizer runtimes, and rebuilds the
kernel (about half a minute in all). A check of the harness itself builds a tiny extension with
an out-of-bounds read and asserts that the same build and run report it.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import sysconfig
from importlib import resources
from pathlib import Path

import pytest

import frcontrol

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "frcontrol" / "_kernel.c"

SANITIZER_FLAGS = ("-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer",
                   "-O1", "-g")
"""How the sanitized extension is compiled: both sanitizers, every report fatal."""

SANITIZED_TESTS = (
    "tests/test_kernel.py",
    "tests/test_compiled_rows.py",
    "tests/test_fast_paths.py::test_compiled_certified_children_are_numpys_certified_responses",
    "tests/test_fast_paths.py::test_compiled_certified_by_rows_are_numpys",
    "tests/test_fast_paths.py::test_certified_by_rows_are_the_svds",
    "tests/test_query.py::test_the_compiled_query_agrees_with_its_numpy_twin",
    "tests/test_query.py::test_the_query_kernel_refuses_bad_buffers",
    "tests/test_query.py::test_the_one_call_query_agrees_with_its_numpy_twin",
    "tests/test_query.py::test_the_one_call_takes_plain_inputs_only",
    "tests/test_query.py::test_the_scratch_query_is_the_general_paths",
    "tests/test_query.py::test_the_scratch_query_takes_plain_inputs_only",
    "tests/test_query.py::test_the_scratch_query_leaves_impacts_springs_and_the_svd_to_the_general_path",
    "tests/test_query.py::test_the_scratch_kernel_refuses_bad_arguments",
    "tests/test_query.py::test_the_one_call_agrees_with_the_batch_path_on_random_problems",
    "tests/test_query.py::test_the_one_call_decides_massless_legs_as_the_batch_path",
    "tests/test_query.py::test_the_one_call_leaves_a_two_variable_choice_it_cannot_make_to_the_general_path",
    "tests/test_query.py::test_a_strided_or_fortran_input_on_every_path",
    "tests/test_simulation_speed.py::test_compiled_lemke_pivots_like_the_numpy_reference",
    "tests/test_simulation_speed.py::test_compiled_lcp_check_agrees_with_numpy",
    "tests/test_simulation_speed.py::test_compiled_coulomb_matrix_and_contact_law_equal_numpy",
    "tests/test_model.py::test_compiled_assembly_refuses_malformed_arguments",
    "tests/test_stability.py::test_compiled_verdicts_are_the_reference_paths",
    "tests/test_stability.py::test_the_compiled_verdict_leaves_an_eigenvalue_on_its_tolerance_to_the_reference",
    "tests/test_stability.py::test_classify_solutions_is_stability_of_on_every_shipped_scene",
    "tests/test_stability.py::test_the_compiled_verdict_refuses_bad_arguments",
    "tests/test_stability.py::test_a_wrong_mode_is_refused_even_after_an_impending_contact",
    "tests/test_stability.py::test_a_nan_friction_on_two_sliding_contacts_is_not_given_a_verdict",
)
"""The tests run against the sanitized build: every function of the extension, on good and bad
arguments."""

REPORTS = ("ERROR: AddressSanitizer", "runtime error:", "SUMMARY: UndefinedBehaviorSanitizer")
"""What a sanitizer writes when it finds something."""

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(os.environ.get("CI") != "true",
                       reason="the sanitizer build runs in CI (CI=true): it needs gcc's ASan and UBSan "
                              "runtimes and rebuilds the kernel (about half a minute)"),
]


def _compiler() -> str:
    compiler = shutil.which("gcc")
    assert compiler is not None, "the sanitizer build needs gcc (CI must have it)"
    return compiler


def _preloaded(compiler: str) -> str:
    """The ASan runtime, and the C++ runtime after it: ASan's interceptor of C++ exceptions finds the
    real ``__cxa_throw`` only when libstdc++ is loaded with it (Pinocchio throws and catches)."""
    paths = [subprocess.run([compiler, f"-print-file-name={name}"], capture_output=True, text=True,
                            check=True).stdout.strip() for name in ("libasan.so", "libstdc++.so.6")]
    for path in paths:
        assert Path(path).is_file(), f"gcc has no {Path(path).name} (needed by the sanitizer run)"
    return " ".join(paths)


def _build(compiler: str, source: Path, target: Path, *defines: str) -> None:
    command = [compiler, "-shared", "-fPIC", *SANITIZER_FLAGS, f"-I{sysconfig.get_paths()['include']}",
               *(f"-D{d}" for d in defines), str(source), "-o", str(target)]
    built = subprocess.run(command, capture_output=True, text=True)
    assert built.returncode == 0, f"the sanitizer build failed:\n{built.stderr}"


def _sanitized_environment(compiler: str, path: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "FRC_KERNEL"}
    # PYTHONMALLOC=malloc: Python's own allocator serves PyMem_Malloc blocks of up to 512 bytes from
    # its arenas, where AddressSanitizer sees no block's end; most of the kernel's scratch is that small
    env.update(PYTHONPATH=str(path), LD_PRELOAD=_preloaded(compiler), PYTHONDONTWRITEBYTECODE="1",
               PYTHONMALLOC="malloc", ASAN_OPTIONS="detect_leaks=0:abort_on_error=1",
               UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1")
    return env


def _package_copy(destination: Path) -> Path:
    """The installed package (its robots and scenes too), without its compiled kernel."""
    package = destination / "frcontrol"
    shutil.copytree(Path(frcontrol.__file__).parent, package,
                    ignore=shutil.ignore_patterns("__pycache__", "*.so", "_kernel.c"))
    robots = package / "robots"
    if not robots.exists():  # an editable install maps frcontrol.robots to the checkout's robots/
        shutil.copytree(Path(str(resources.files("frcontrol.robots"))), robots,
                        ignore=shutil.ignore_patterns("__pycache__"))
    return package


def test_the_kernel_tests_pass_under_asan_and_ubsan(tmp_path):
    compiler = _compiler()
    package = _package_copy(tmp_path)
    digest = hashlib.sha256(SOURCE.read_bytes()).hexdigest()
    _build(compiler, SOURCE, package / f"_kernel{sysconfig.get_config_var('EXT_SUFFIX')}",
           f'FRC_KERNEL_SOURCE_SHA256="{digest}"')
    env = _sanitized_environment(compiler, tmp_path)
    # run from the copy's folder: python puts the working folder first on sys.path, and the
    # checkout's own frcontrol/ would be imported instead
    which = subprocess.run([sys.executable, "-c", "import frcontrol._kernel as k; print(k.__file__)"],
                           capture_output=True, text=True, env=env, cwd=tmp_path)
    assert which.returncode == 0, which.stderr
    assert Path(which.stdout.strip()).parent == package, "the sanitized build is not the one imported"
    tests = [str(ROOT / test) for test in SANITIZED_TESTS]
    # --capture=sys: a sanitizer writes its report to file descriptor 2 and aborts; pytest's
    # capture of that descriptor would lose it
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--capture=sys",
                          "--rootdir", str(ROOT), "-c", str(ROOT / "pyproject.toml"), *tests],
                         capture_output=True, text=True, env=env, cwd=tmp_path)
    output = run.stdout + run.stderr
    reported = [output.index(r) for r in REPORTS if r in output]
    assert not reported, output[min(reported):][:6000]
    assert run.returncode == 0, output[-6000:]
    assert " passed" in run.stdout and " skipped" not in run.stdout.splitlines()[-1], run.stdout[-2000:]


BROKEN = r"""
#define PY_SSIZE_T_CLEAN
#include <Python.h>
static PyObject *read_past(PyObject *self, PyObject *arg) {
    (void)self;
    long n = PyLong_AsLong(arg);
    double *v = PyMem_Malloc(4 * sizeof(double));  /* 32 bytes: pymalloc's, without PYTHONMALLOC=malloc */
    for (int i = 0; i < 4; i++) v[i] = i;
    double x = v[n];  /* n = 4: one past the end */
    PyMem_Free(v);
    return PyFloat_FromDouble(x);
}
static PyMethodDef methods[] = {{"read_past", read_past, METH_O, NULL}, {NULL, NULL, 0, NULL}};
static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "broken", NULL, -1, methods};
PyMODINIT_FUNC PyInit_broken(void) { return PyModule_Create(&module); }
"""


def test_the_harness_reports_an_out_of_bounds_read(tmp_path):
    compiler = _compiler()
    source = tmp_path / "broken.c"
    source.write_text(BROKEN)
    _build(compiler, source, tmp_path / f"broken{sysconfig.get_config_var('EXT_SUFFIX')}")
    env = _sanitized_environment(compiler, tmp_path)
    fine = subprocess.run([sys.executable, "-c", "import broken; print(broken.read_past(3))"],
                          capture_output=True, text=True, env=env)
    assert fine.returncode == 0 and fine.stdout.strip() == "3.0", fine.stderr
    run = subprocess.run([sys.executable, "-c", "import broken; print(broken.read_past(4))"],
                         capture_output=True, text=True, env=env)
    assert run.returncode != 0
    assert "ERROR: AddressSanitizer: heap-buffer-overflow" in run.stderr, run.stderr[-3000:]
