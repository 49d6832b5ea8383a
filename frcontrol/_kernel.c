/* The compiled kernel of frcontrol.mode_batch: the certified-modes path of decide_modes.
 *
 * Plain C against the CPython API and the buffer protocol (no NumPy headers): the build needs only
 * setuptools, a C compiler and Python's headers. frcontrol/kernel.py wraps it; the NumPy code in
 * frcontrol/mode_batch.py (_stack, _equilibrate, _certified_responses, _decide_full_rank) is the
 * reference it reproduces, mode by mode:
 *
 *   1. A = [dynamics; the contact row table's equalities of the mode's letters], its right side
 *      rhs = c + [S^T u; 0] with c = [-h; the equalities' right sides];
 *   2. power-of-two row scalings r (of max |A| per row), then column scalings s (of max |r A| per
 *      column): A_hat = diag(r) A diag(s), as _equilibrate;
 *   3. an LU factorisation of A_hat with partial pivoting solving
 *      A_hat Y = [I, diag(r) B, diag(r) rhs]; an exactly zero pivot: not certified;
 *   4. certified when ||A_hat||_F ||A_hat^-1||_F * margin * tolerance < 1 (CERTIFIED_MARGIN);
 *   5. x = diag(s) y_last, X_u = diag(s) Y_B; each valid inequality row G_i at u: its norm in u
 *      ||G_i X_u||, rows below the zero-row threshold normalised by 1, the slack
 *      -(G_i x - g_i) / norm; motion rows must exceed the domain tolerance, the others reach its
 *      negative;
 *   6. the equality residual max |A x - rhs| and the inequality violation max(G x - g, 0).
 *
 * Every buffer is checked (format, dimensions, shape, C-contiguity, writability); a wrong one
 * raises frcontrol.errors.KernelError, never a crash.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

#define LETTERS 4          /* S, L, R, F */
#define EQUALITY_ROWS 2    /* equality rows per contact */
#define INEQUALITY_ROWS 3  /* ROWS_PER_CONTACT */

enum { NOT_CERTIFIED = 0, CERTIFIED_INADMISSIBLE = 1, CERTIFIED_ADMISSIBLE = 2 };

static PyObject *kernel_error = NULL; /* frcontrol.errors.KernelError */

typedef struct {
    Py_buffer view;
    int held;
} Buffer;

static int format_is(const char *format, char kind) {
    const char *f = format ? format : "B";
    if (*f == '@' || *f == '=' || *f == '<') {
        f++;
    }
    if (f[1] != '\0') {
        return 0;
    }
    switch (kind) {
    case 'd':
        return f[0] == 'd';
    case '?':
        return f[0] == '?';
    case 'q':
        return f[0] == 'q' || (f[0] == 'l' && sizeof(long) == 8);
    case 'b':
        return f[0] == 'b';
    default:
        return 0;
    }
}

/* Take a C-contiguous buffer of the given kind ('d' float64, '?' bool, 'q' int64, 'b' int8) and
 * number of dimensions; shape entries >= 0 must match, -1 is read back. */
static int take(PyObject *obj, Buffer *b, const char *name, char kind, int ndim, Py_ssize_t *shape,
                int writable) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, &b->view, flags) != 0) {
        PyErr_Clear();
        PyErr_Format(kernel_error, "kernel buffer %s: not a C-contiguous%s buffer", name,
                     writable ? ", writable" : "");
        return -1;
    }
    b->held = 1;
    if (!format_is(b->view.format, kind)) {
        PyErr_Format(kernel_error, "kernel buffer %s: format %s, expected %s", name,
                     b->view.format ? b->view.format : "B",
                     kind == 'd' ? "float64" : kind == '?' ? "bool" : kind == 'q' ? "int64" : "int8");
        return -1;
    }
    if (b->view.ndim != ndim) {
        PyErr_Format(kernel_error, "kernel buffer %s: %d dimensions, expected %d", name, b->view.ndim,
                     ndim);
        return -1;
    }
    for (int i = 0; i < ndim; i++) {
        if (shape[i] < 0) {
            shape[i] = b->view.shape[i];
        } else if (b->view.shape[i] != shape[i]) {
            PyErr_Format(kernel_error, "kernel buffer %s: axis %d has %zd entries, expected %zd", name, i,
                         b->view.shape[i], shape[i]);
            return -1;
        }
    }
    return 0;
}

/* 2^-round(log2 t), 1 where t is 0: frcontrol.response.power_of_two_scale (round half to even). */
static double power_of_two_scale(double top) {
    if (!(top > 0.0)) {
        return 1.0;
    }
    return exp2(-nearbyint(log2(top)));
}

typedef struct {
    Py_ssize_t n, k, m, nx, count;
    const double *dynamics, *eq, *eq_rhs, *ineq, *ineq_rhs, *input_map, *bias, *u;
    const unsigned char *valid, *motion;
    const long long *letters;
    double margin, tolerance, domain_tolerance, zero_row_tolerance;
    signed char *status;
    double *x, *residual, *violation;
} Problem;

typedef struct {
    double *A, *A_hat, *Y, *rhs, *r_scale, *c_scale, *X_u, *xs;
} Scratch;

/* Steps 1-2: the mode's A, its right side and the equilibrated A_hat. */
static void assemble(const Problem *p, const long long *letters, const double *Su, Scratch *s) {
    Py_ssize_t n = p->n, nx = p->nx;
    memcpy(s->A, p->dynamics, (size_t)(n * nx) * sizeof(double));
    for (Py_ssize_t i = 0; i < n; i++) {
        s->rhs[i] = -p->bias[i] + Su[i];
    }
    for (Py_ssize_t j = 0; j < p->k; j++) {
        Py_ssize_t cell = j * LETTERS + letters[j];
        for (Py_ssize_t r = 0; r < EQUALITY_ROWS; r++) {
            Py_ssize_t row = n + EQUALITY_ROWS * j + r;
            memcpy(s->A + row * nx, p->eq + (cell * EQUALITY_ROWS + r) * nx, (size_t)nx * sizeof(double));
            s->rhs[row] = p->eq_rhs[cell * EQUALITY_ROWS + r];
        }
    }
    for (Py_ssize_t i = 0; i < nx; i++) {
        double top = 0.0;
        for (Py_ssize_t j = 0; j < nx; j++) {
            double a = fabs(s->A[i * nx + j]);
            top = a > top ? a : top;
        }
        s->r_scale[i] = power_of_two_scale(top);
    }
    for (Py_ssize_t j = 0; j < nx; j++) {
        double top = 0.0;
        for (Py_ssize_t i = 0; i < nx; i++) {
            double a = fabs(s->A[i * nx + j] * s->r_scale[i]);
            top = a > top ? a : top;
        }
        s->c_scale[j] = power_of_two_scale(top);
    }
    for (Py_ssize_t i = 0; i < nx; i++) {
        for (Py_ssize_t j = 0; j < nx; j++) {
            s->A_hat[i * nx + j] = s->A[i * nx + j] * s->r_scale[i] * s->c_scale[j];
        }
    }
}

/* Step 3: A_hat Y = [I, diag(r) B, diag(r) rhs] by LU with partial pivoting (A_hat is overwritten).
 * Returns 0 on an exactly zero pivot. */
static int lu_solve(const Problem *p, Scratch *s) {
    Py_ssize_t n = p->n, nx = p->nx, m = p->m, w = nx + m + 1;
    double *a = s->A_hat, *y = s->Y;
    memset(y, 0, (size_t)(nx * w) * sizeof(double));
    for (Py_ssize_t i = 0; i < nx; i++) {
        y[i * w + i] = 1.0;
        if (i < n) {
            for (Py_ssize_t j = 0; j < m; j++) {
                y[i * w + nx + j] = p->input_map[i * m + j] * s->r_scale[i];
            }
        }
        y[i * w + w - 1] = s->rhs[i] * s->r_scale[i];
    }
    for (Py_ssize_t c = 0; c < nx; c++) {
        Py_ssize_t pivot = c;
        double best = fabs(a[c * nx + c]);
        for (Py_ssize_t i = c + 1; i < nx; i++) {
            double v = fabs(a[i * nx + c]);
            if (v > best) {
                best = v;
                pivot = i;
            }
        }
        if (best == 0.0) {
            return 0;
        }
        if (pivot != c) {
            for (Py_ssize_t j = 0; j < nx; j++) {
                double t = a[c * nx + j];
                a[c * nx + j] = a[pivot * nx + j];
                a[pivot * nx + j] = t;
            }
            for (Py_ssize_t j = 0; j < w; j++) {
                double t = y[c * w + j];
                y[c * w + j] = y[pivot * w + j];
                y[pivot * w + j] = t;
            }
        }
        double inv = 1.0 / a[c * nx + c];
        for (Py_ssize_t i = c + 1; i < nx; i++) {
            double l = a[i * nx + c] * inv;
            if (l == 0.0) {
                continue;
            }
            for (Py_ssize_t j = c + 1; j < nx; j++) {
                a[i * nx + j] -= l * a[c * nx + j];
            }
            for (Py_ssize_t j = 0; j < w; j++) {
                y[i * w + j] -= l * y[c * w + j];
            }
        }
    }
    for (Py_ssize_t c = nx - 1; c >= 0; c--) {
        double d = a[c * nx + c];
        for (Py_ssize_t j = 0; j < w; j++) {
            double v = y[c * w + j];
            for (Py_ssize_t i = c + 1; i < nx; i++) {
                v -= a[c * nx + i] * y[i * w + j];
            }
            y[c * w + j] = v / d;
        }
    }
    return 1;
}

/* Step 4: ||A_hat||_F ||A_hat^-1||_F margin tolerance < 1 (sum_A2 taken before the LU). */
static int certified_bound(const Problem *p, const Scratch *s, double sum_a2) {
    Py_ssize_t nx = p->nx, w = nx + p->m + 1;
    double sum_y2 = 0.0;
    for (Py_ssize_t i = 0; i < nx; i++) {
        for (Py_ssize_t j = 0; j < nx; j++) {
            double v = s->Y[i * w + j];
            sum_y2 += v * v;
        }
    }
    double bound = sqrt(sum_a2 * sum_y2);
    return bound * p->margin * p->tolerance < 1.0;
}

/* Steps 5-6 for a certified mode: its inequality rows at u, the residual and the violation. */
static int decide(const Problem *p, const long long *letters, const Scratch *s, double *residual,
                  double *violation) {
    Py_ssize_t nx = p->nx, m = p->m, k = p->k;
    double largest = 0.0;
    int admissible = 1;
    /* first pass: the largest valid row norm in u */
    for (Py_ssize_t j = 0; j < k; j++) {
        Py_ssize_t cell = j * LETTERS + letters[j];
        for (Py_ssize_t r = 0; r < INEQUALITY_ROWS; r++) {
            if (!p->valid[cell * INEQUALITY_ROWS + r]) {
                continue;
            }
            const double *g = p->ineq + (cell * INEQUALITY_ROWS + r) * nx;
            double sq = 0.0;
            for (Py_ssize_t c = 0; c < m; c++) {
                double h = 0.0;
                for (Py_ssize_t i = 0; i < nx; i++) {
                    h += g[i] * s->X_u[i * m + c];
                }
                sq += h * h;
            }
            double norm = sqrt(sq);
            largest = norm > largest ? norm : largest;
        }
    }
    double floor = p->zero_row_tolerance * (largest > 1.0 ? largest : 1.0);
    double worst = 0.0;
    for (Py_ssize_t j = 0; j < k; j++) {
        Py_ssize_t cell = j * LETTERS + letters[j];
        for (Py_ssize_t r = 0; r < INEQUALITY_ROWS; r++) {
            Py_ssize_t row = cell * INEQUALITY_ROWS + r;
            if (!p->valid[row]) {
                continue;
            }
            const double *g = p->ineq + row * nx;
            double sq = 0.0, gx = 0.0;
            for (Py_ssize_t c = 0; c < m; c++) {
                double h = 0.0;
                for (Py_ssize_t i = 0; i < nx; i++) {
                    h += g[i] * s->X_u[i * m + c];
                }
                sq += h * h;
            }
            for (Py_ssize_t i = 0; i < nx; i++) {
                gx += g[i] * s->xs[i];
            }
            double norm = sqrt(sq);
            norm = norm <= floor ? 1.0 : norm;
            double bad = gx - p->ineq_rhs[row];
            double slack = -bad / norm;
            worst = bad > worst ? bad : worst;
            int holds = p->motion[row] ? slack > p->domain_tolerance : slack >= -p->domain_tolerance;
            admissible &= holds;
        }
    }
    double res = 0.0;
    for (Py_ssize_t i = 0; i < nx; i++) {
        double ax = 0.0;
        for (Py_ssize_t j = 0; j < nx; j++) {
            ax += s->A[i * nx + j] * s->xs[j];
        }
        double d = fabs(ax - s->rhs[i]);
        res = d > res ? d : res;
    }
    *residual = res;
    *violation = worst;
    return admissible;
}

static void run_modes(const Problem *p, const double *Su, Scratch *s) {
    Py_ssize_t nx = p->nx, m = p->m, w = nx + m + 1;
    for (Py_ssize_t mode = 0; mode < p->count; mode++) {
        const long long *letters = p->letters + mode * p->k;
        double *x = p->x + mode * nx;
        memset(x, 0, (size_t)nx * sizeof(double));
        p->residual[mode] = 0.0;
        p->violation[mode] = 0.0;
        p->status[mode] = NOT_CERTIFIED;
        assemble(p, letters, Su, s);
        double sum_a2 = 0.0;
        for (Py_ssize_t i = 0; i < nx * nx; i++) {
            sum_a2 += s->A_hat[i] * s->A_hat[i];
        }
        if (!lu_solve(p, s) || !certified_bound(p, s, sum_a2)) {
            continue;
        }
        for (Py_ssize_t i = 0; i < nx; i++) {
            s->xs[i] = s->c_scale[i] * s->Y[i * w + w - 1];
            for (Py_ssize_t c = 0; c < m; c++) {
                s->X_u[i * m + c] = s->c_scale[i] * s->Y[i * w + nx + c];
            }
        }
        memcpy(x, s->xs, (size_t)nx * sizeof(double));
        int ok = decide(p, letters, s, &p->residual[mode], &p->violation[mode]);
        p->status[mode] = ok ? CERTIFIED_ADMISSIBLE : CERTIFIED_INADMISSIBLE;
    }
}

#define ARGS 19
static const char *arg_names[ARGS] = {
    "dynamics", "equalities", "equality_rhs", "inequalities", "inequality_rhs", "valid", "motion",
    "letters", "input_map", "bias", "u", "status", "x", "residual", "violation", "margin", "tolerance",
    "domain_tolerance", "zero_row_tolerance"};

/* Take the 15 buffers, reading n, nx, k, m and the mode count from the first ones seen. */
static int take_all(PyObject *const *args, Buffer *b, Problem *p) {
    Py_ssize_t s_dyn[2] = {-1, -1};
    if (take(args[0], &b[0], arg_names[0], 'd', 2, s_dyn, 0)) return -1;
    Py_ssize_t n = s_dyn[0], nx = s_dyn[1];
    Py_ssize_t s_eq[4] = {-1, LETTERS, EQUALITY_ROWS, nx};
    if (take(args[1], &b[1], arg_names[1], 'd', 4, s_eq, 0)) return -1;
    Py_ssize_t k = s_eq[0];
    if (nx != n + 2 * k) {
        PyErr_Format(kernel_error, "kernel buffer dynamics: %zd columns, expected n + 2k = %zd", nx,
                     n + 2 * k);
        return -1;
    }
    Py_ssize_t s_eqr[3] = {k, LETTERS, EQUALITY_ROWS};
    Py_ssize_t s_in[4] = {k, LETTERS, INEQUALITY_ROWS, nx};
    Py_ssize_t s_inr[3] = {k, LETTERS, INEQUALITY_ROWS};
    Py_ssize_t s_valid[3] = {k, LETTERS, INEQUALITY_ROWS};
    Py_ssize_t s_motion[3] = {k, LETTERS, INEQUALITY_ROWS};
    Py_ssize_t s_letters[2] = {-1, k};
    Py_ssize_t s_map[2] = {n, -1};
    if (take(args[2], &b[2], arg_names[2], 'd', 3, s_eqr, 0) ||
        take(args[3], &b[3], arg_names[3], 'd', 4, s_in, 0) ||
        take(args[4], &b[4], arg_names[4], 'd', 3, s_inr, 0) ||
        take(args[5], &b[5], arg_names[5], '?', 3, s_valid, 0) ||
        take(args[6], &b[6], arg_names[6], '?', 3, s_motion, 0) ||
        take(args[7], &b[7], arg_names[7], 'q', 2, s_letters, 0) ||
        take(args[8], &b[8], arg_names[8], 'd', 2, s_map, 0)) {
        return -1;
    }
    Py_ssize_t count = s_letters[0], m = s_map[1];
    Py_ssize_t s_bias[1] = {n}, s_u[1] = {m}, s_status[1] = {count}, s_x[2] = {count, nx};
    Py_ssize_t s_res[1] = {count}, s_vio[1] = {count};
    if (take(args[9], &b[9], arg_names[9], 'd', 1, s_bias, 0) ||
        take(args[10], &b[10], arg_names[10], 'd', 1, s_u, 0) ||
        take(args[11], &b[11], arg_names[11], 'b', 1, s_status, 1) ||
        take(args[12], &b[12], arg_names[12], 'd', 2, s_x, 1) ||
        take(args[13], &b[13], arg_names[13], 'd', 1, s_res, 1) ||
        take(args[14], &b[14], arg_names[14], 'd', 1, s_vio, 1)) {
        return -1;
    }
    p->n = n, p->k = k, p->m = m, p->nx = nx, p->count = count;
    p->dynamics = b[0].view.buf, p->eq = b[1].view.buf, p->eq_rhs = b[2].view.buf;
    p->ineq = b[3].view.buf, p->ineq_rhs = b[4].view.buf;
    p->valid = b[5].view.buf, p->motion = b[6].view.buf, p->letters = b[7].view.buf;
    p->input_map = b[8].view.buf, p->bias = b[9].view.buf, p->u = b[10].view.buf;
    p->status = b[11].view.buf, p->x = b[12].view.buf, p->residual = b[13].view.buf;
    p->violation = b[14].view.buf;
    for (Py_ssize_t i = 0; i < count * k; i++) {
        if (p->letters[i] < 0 || p->letters[i] >= LETTERS) {
            PyErr_Format(kernel_error, "kernel buffer letters: entry %lld is not a letter index 0-3",
                         p->letters[i]);
            return -1;
        }
    }
    return 0;
}

static int take_floats(PyObject *const *args, Problem *p) {
    double *dest[4] = {&p->margin, &p->tolerance, &p->domain_tolerance, &p->zero_row_tolerance};
    for (int i = 0; i < 4; i++) {
        double v = PyFloat_AsDouble(args[15 + i]);
        if (v == -1.0 && PyErr_Occurred()) {
            PyErr_Clear();
            PyErr_Format(kernel_error, "kernel argument %s: not a number", arg_names[15 + i]);
            return -1;
        }
        *dest[i] = v;
    }
    return 0;
}

static PyObject *certified_modes(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != ARGS) {
        PyErr_Format(kernel_error, "certified_modes takes %d arguments, got %zd", ARGS, nargs);
        return NULL;
    }
    Buffer b[15];
    memset(b, 0, sizeof(b));
    Problem p;
    PyObject *result = NULL;
    double *memory = NULL;
    if (take_all(args, b, &p) || take_floats(args, &p)) {
        goto done;
    }
    Py_ssize_t nx = p.nx, w = nx + p.m + 1;
    Py_ssize_t size = 4 * nx * nx + nx * w + 4 * nx + nx * p.m + p.n + 1;
    memory = PyMem_Malloc((size_t)size * sizeof(double));
    if (memory == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Scratch s;
    double *at = memory;
    s.A = at, at += nx * nx;
    s.A_hat = at, at += nx * nx;
    s.Y = at, at += nx * w;
    s.rhs = at, at += nx;
    s.r_scale = at, at += nx;
    s.c_scale = at, at += nx;
    s.xs = at, at += nx;
    s.X_u = at, at += nx * p.m;
    double *Su = at;
    for (Py_ssize_t i = 0; i < p.n; i++) {
        double v = 0.0;
        for (Py_ssize_t j = 0; j < p.m; j++) {
            v += p.input_map[i * p.m + j] * p.u[j];
        }
        Su[i] = v;
    }
    run_modes(&p, Su, &s);
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(memory);
    for (int i = 0; i < 15; i++) {
        if (b[i].held) {
            PyBuffer_Release(&b[i].view);
        }
    }
    return result;
}

static PyMethodDef methods[] = {
    {"certified_modes", (PyCFunction)(void (*)(void))certified_modes, METH_FASTCALL,
     "certified_modes(dynamics, equalities, equality_rhs, inequalities, inequality_rhs, valid, motion,\n"
     "                letters, input_map, bias, u, status, x, residual, violation, margin, tolerance,\n"
     "                domain_tolerance, zero_row_tolerance) -> None\n\n"
     "Every mode of `letters` (count, k): certified or not, and, when certified, its x, whether its\n"
     "inequalities hold at u, its equality residual and inequality violation, written into the\n"
     "output buffers status (int8: 0 not certified, 1 certified and inadmissible, 2 certified and\n"
     "admissible), x (count, nx), residual (count,) and violation (count,)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "frcontrol._kernel",
                                    "The compiled certified-modes kernel of frcontrol.mode_batch.", -1,
                                    methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__kernel(void) {
    PyObject *errors = PyImport_ImportModule("frcontrol.errors");
    if (errors == NULL) {
        return NULL;
    }
    kernel_error = PyObject_GetAttrString(errors, "KernelError");
    Py_DECREF(errors);
    if (kernel_error == NULL) {
        return NULL;
    }
    PyObject *mod = PyModule_Create(&module);
    if (mod == NULL) {
        return NULL;
    }
    PyModule_AddIntConstant(mod, "NOT_CERTIFIED", NOT_CERTIFIED);
    PyModule_AddIntConstant(mod, "CERTIFIED_INADMISSIBLE", CERTIFIED_INADMISSIBLE);
    PyModule_AddIntConstant(mod, "CERTIFIED_ADMISSIBLE", CERTIFIED_ADMISSIBLE);
    return mod;
}
