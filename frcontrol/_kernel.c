/* The compiled kernel of frcontrol.mode_batch (the certified-modes path of decide_modes), of
 * frcontrol.query (locate_points, evaluate_points: queries on an analysis), of frcontrol.engine
 * (scratch_plan, scratch_solutions, problem_solutions: the single query from scratch in one call) and of frcontrol.lcp
 * and frcontrol.simulation (lemke: the pivots of Lemke's method; lcp_check: the check of its
 * answer; coulomb_matrix: the LCP of the rigid simulation's step; compliant_law: the compliant
 * contact law) and of frcontrol.polytope (redundancy_rows, ray_exit: the steps of Clarkson's
 * redundancy loop around its LP).
 *
 * Plain C against the CPython API and the buffer protocol (no NumPy headers): the build needs only
 * setuptools, a C compiler and Python's headers. frcontrol/kernel.py puts it behind one seam (the
 * COMPILED backend; each function's NumPy twin lives beside its caller). Every function's
 * arguments are described by one table and read by one parser (parse, "arguments" below). The
 * tests run against a build with AddressSanitizer and UBSan too (tests/test_sanitizer.py). The
 * NumPy code in frcontrol/mode_batch.py (_stack, _equilibrate, _certified_responses,
 * _decide_full_rank) is the reference certified_modes reproduces, mode by mode:
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
#include <float.h>
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

/* Shape entries >= 0 must match the buffer's; -1 entries are read back. */
static int match_shape(const Py_buffer *view, const char *name, int ndim, Py_ssize_t *shape) {
    for (int i = 0; i < ndim; i++) {
        if (shape[i] < 0) {
            shape[i] = view->shape[i];
        } else if (view->shape[i] != shape[i]) {
            PyErr_Format(kernel_error, "kernel buffer %s: axis %d has %zd entries, expected %zd", name, i,
                         view->shape[i], shape[i]);
            return -1;
        }
    }
    return 0;
}

/* Take a C-contiguous buffer of the given kind ('d' float64, '?' bool, 'q' int64, 'b' int8) and
 * number of dimensions (match_shape). */
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
    return match_shape(&b->view, name, ndim, shape);
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
    double *a_hat_out, *r_out, *c_out; /* certified_modes: every mode's A_hat and scalings (NULL: none) */
} Problem;

typedef struct {
    double *A, *A_hat, *Y, *rhs, *c, *r_scale, *c_scale, *X_u, *xs;
} Scratch;

/* Steps 1-2: the mode's A, its right side and the equilibrated A_hat. */
static void assemble(const Problem *p, const long long *letters, const double *Su, Scratch *s) {
    Py_ssize_t n = p->n, nx = p->nx;
    memcpy(s->A, p->dynamics, (size_t)(n * nx) * sizeof(double));
    for (Py_ssize_t i = 0; i < n; i++) {
        s->c[i] = -p->bias[i];
        s->rhs[i] = s->c[i] + Su[i];
    }
    for (Py_ssize_t j = 0; j < p->k; j++) {
        Py_ssize_t cell = j * LETTERS + letters[j];
        for (Py_ssize_t r = 0; r < EQUALITY_ROWS; r++) {
            Py_ssize_t row = n + EQUALITY_ROWS * j + r;
            memcpy(s->A + row * nx, p->eq + (cell * EQUALITY_ROWS + r) * nx, (size_t)nx * sizeof(double));
            s->c[row] = s->rhs[row] = p->eq_rhs[cell * EQUALITY_ROWS + r];
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
        if (p->a_hat_out != NULL) {
            memcpy(p->a_hat_out + mode * nx * nx, s->A_hat, (size_t)(nx * nx) * sizeof(double));
            memcpy(p->r_out + mode * nx, s->r_scale, (size_t)nx * sizeof(double));
            memcpy(p->c_out + mode * nx, s->c_scale, (size_t)nx * sizeof(double));
        }
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

/* ------------------------------------------------------------------ the rank-deficient modes */

typedef struct {
    const double *U, *s, *Vt, *r_in, *c_in;
    double rank_tolerance, band, radius_cap, consistency_tolerance, output_tolerance;
    double *w;
    signed char *outputs;
} Ranked;

enum { INADMISSIBLE = 0, ADMISSIBLE = 1, NEEDS_PYTHON = 2, ADMISSIBLE_W = 3 };
enum { MOVES_NONE = 0, MOVES_FORCES = 1, MOVES_ACCELERATIONS = 2 };

static Py_ssize_t rank_of(const double *s, Py_ssize_t nx, double rank_tolerance) {
    if (nx == 0 || !(s[0] > 0.0)) {
        return 0;
    }
    Py_ssize_t rank = 0;
    for (Py_ssize_t i = 0; i < nx; i++) {
        rank += s[i] > rank_tolerance * s[0];
    }
    return rank;
}

/* The responses of a mode of rank r = nx - p (p <= 1), by solve_affine's formulas: with
 * Bc = diag(r) [B c], X_u and x_0 = diag(c) V1 diag(1/s) U1^T Bc, X_w = diag(c) V2, and the
 * consistency row left = U2^T Bc. Writes X_u (nx, m), x0 (nx), X_w (nx), left (m + 1). */
static void responses(const Problem *p, const Ranked *q, Py_ssize_t mode, Py_ssize_t r, const Scratch *s,
                      double *X_u, double *x0, double *X_w, double *left) {
    Py_ssize_t nx = p->nx, n = p->n, m = p->m, w = m + 1;
    const double *U = q->U + mode * nx * nx, *sv = q->s + mode * nx, *Vt = q->Vt + mode * nx * nx;
    const double *rs = q->r_in + mode * nx, *cs = q->c_in + mode * nx;
    double *T = s->Y; /* r x (m + 1): diag(1/s) U1^T Bc */
    for (Py_ssize_t a = 0; a <= r && a < nx; a++) {
        double *row = a < r ? T + a * w : left;
        for (Py_ssize_t j = 0; j < w; j++) {
            double v = 0.0;
            for (Py_ssize_t i = 0; i < nx; i++) {
                double bc = j < m ? (i < n ? p->input_map[i * m + j] * rs[i] : 0.0) : s->c[i] * rs[i];
                v += U[i * nx + a] * bc;
            }
            row[j] = a < r ? (1.0 / sv[a]) * v : v;
        }
    }
    for (Py_ssize_t i = 0; i < nx; i++) {
        for (Py_ssize_t j = 0; j < w; j++) {
            double v = 0.0;
            for (Py_ssize_t a = 0; a < r; a++) {
                v += Vt[a * nx + i] * T[a * w + j];
            }
            if (j < m) {
                X_u[i * m + j] = cs[i] * v;
            } else {
                x0[i] = cs[i] * v;
            }
        }
        X_w[i] = r < nx ? cs[i] * Vt[r * nx + i] : 0.0;
    }
}

/* _consistent_at for p <= 1 with _scale_of's scale of diag(r) [B c]. */
static int consistent(const Problem *p, const Ranked *q, Py_ssize_t mode, Py_ssize_t pdim, const Scratch *s,
                      const double *left) {
    if (pdim == 0) {
        return 1;
    }
    Py_ssize_t nx = p->nx, n = p->n, m = p->m;
    const double *rs = q->r_in + mode * nx;
    double scale = 0.0;
    for (Py_ssize_t i = 0; i < nx; i++) {
        for (Py_ssize_t j = 0; j < m && i < n; j++) {
            double v = fabs(p->input_map[i * m + j] * rs[i]);
            scale = v > scale ? v : scale;
        }
        double v = fabs(s->c[i] * rs[i]);
        scale = v > scale ? v : scale;
    }
    scale = scale > 1.0 ? scale : 1.0;
    double e = -left[m], limit = q->consistency_tolerance * scale;
    double sq = 0.0, eu = 0.0;
    for (Py_ssize_t j = 0; j < m; j++) {
        sq += left[j] * left[j];
        eu += left[j] * p->u[j];
    }
    double norm = sqrt(sq);
    if (m == 0 || !(norm > limit)) {
        return !(fabs(e) > limit);
    }
    return fabs(eu - e) / norm <= p->domain_tolerance;
}

/* decide_intervals for one mode: rows a_i w <= h_i over the valid rows (a, h, motion), with the
 * domain tolerance dt, the zero-row tolerance zrt and the radius cap. */
static int interval_rows(Py_ssize_t rows, const double *a, const double *h, const unsigned char *motion,
                         double dt, double zrt, double radius_cap, double *centre) {
    double top = 0.0, inf = INFINITY;
    for (Py_ssize_t i = 0; i < rows; i++) {
        top = fabs(a[i]) > top ? fabs(a[i]) : top;
    }
    double floor = zrt * (top > 1.0 ? top : 1.0);
    double lo = -inf, hi = inf, lower = -inf, upper = inf, lo_ball = -inf, hi_ball = inf;
    int ok = 1, has_motion = 0;
    for (Py_ssize_t i = 0; i < rows; i++) {
        double relaxed = h[i] + (motion[i] ? 0.0 : dt);
        if (fabs(a[i]) <= floor) {
            ok &= motion[i] ? !(h[i] <= dt) : !(relaxed < 0.0);
            continue;
        }
        double end = relaxed / a[i], ball = (h[i] + dt) / a[i];
        if (a[i] > 0) {
            hi_ball = ball < hi_ball ? ball : hi_ball;
        } else if (a[i] < 0) {
            lo_ball = ball > lo_ball ? ball : lo_ball;
        }
        if (motion[i]) {
            has_motion = 1;
            if (a[i] > 0) {
                upper = end < upper ? end : upper;
            } else if (a[i] < 0) {
                lower = end > lower ? end : lower;
            }
        } else if (a[i] > 0) {
            hi = end < hi ? end : hi;
        } else if (a[i] < 0) {
            lo = end > lo ? end : lo;
        }
    }
    ok &= lo <= hi;
    int fu = isfinite(upper), fd = isfinite(lower);
    double w = fu && fd ? 0.5 * (upper + lower) : fu ? upper - 1.0 : fd ? lower + 1.0 : 0.0;
    w = has_motion ? w : 0.0;
    w = fmin(fmax(w, lo), hi);
    double margin = fmin(1.0, fmin(upper - w, w - lower));
    ok &= !has_motion || (margin >= 0.0 && margin > dt);
    int flo = isfinite(lo_ball), fhi = isfinite(hi_ball);
    double one_side = flo ? lo_ball + radius_cap : fhi ? hi_ball - radius_cap : w;
    *centre = flo && fhi ? (hi_ball - lo_ball > 2.0 * dt ? 0.5 * (lo_ball + hi_ball) : w) : one_side;
    return ok;
}

static int interval(const Problem *p, const Ranked *q, Py_ssize_t rows, const double *a, const double *h,
                    const unsigned char *motion, double *centre) {
    return interval_rows(rows, a, h, motion, p->domain_tolerance, p->zero_row_tolerance, q->radius_cap, centre);
}

/* The largest |X_w[i, t]| of row i of X_w (nx, pdim). */
static double row_top(const double *X_w, Py_ssize_t i, Py_ssize_t pdim) {
    double top = 0.0;
    for (Py_ssize_t t = 0; t < pdim; t++) {
        top = fabs(X_w[i * pdim + t]) > top ? fabs(X_w[i * pdim + t]) : top;
    }
    return top;
}

/* outputs_moved_by for the directions X_w (nx, pdim). */
static signed char moved_by(const Problem *p, const Ranked *q, const double *X_w, Py_ssize_t pdim) {
    double top = 0.0;
    for (Py_ssize_t i = 0; i < p->nx; i++) {
        double row = row_top(X_w, i, pdim);
        top = row > top ? row : top;
    }
    double threshold = q->output_tolerance * (top > 1e-300 ? top : 1e-300);
    int moves_dv = 0, moves_forces = 0;
    for (Py_ssize_t i = 0; i < p->nx; i++) {
        if (row_top(X_w, i, pdim) > threshold) {
            *(i < p->n ? &moves_dv : &moves_forces) = 1;
        }
    }
    return moves_dv ? MOVES_ACCELERATIONS : moves_forces ? MOVES_FORCES : MOVES_NONE;
}

/* The inequality rows at u as a_i w <= h_i (rows normalised in (u, w)), for X_w (nx, pdim), pdim <= 2;
 * p = 0 decides them here. Writes the valid rows' a (rows, pdim), h, motion; returns their count, or -1
 * when p = 0 and a row fails. */
static Py_ssize_t sliced_rows(const Problem *p, const long long *letters, Py_ssize_t pdim, const double *X_u,
                              const double *x0, const double *X_w, double *a, double *h, unsigned char *mo) {
    Py_ssize_t nx = p->nx, m = p->m, rows = 0;
    double largest = 0.0;
    for (int pass = 0; pass < 2; pass++) {
        double floor = p->zero_row_tolerance * (largest > 1.0 ? largest : 1.0);
        rows = 0;
        for (Py_ssize_t j = 0; j < p->k; j++) {
            Py_ssize_t cell = j * LETTERS + letters[j];
            for (Py_ssize_t r = 0; r < INEQUALITY_ROWS; r++) {
                Py_ssize_t row = cell * INEQUALITY_ROWS + r;
                if (!p->valid[row]) {
                    continue;
                }
                const double *g = p->ineq + row * nx;
                double sq = 0.0, hu = 0.0, gx0 = 0.0, hw[2] = {0.0, 0.0};
                for (Py_ssize_t c = 0; c < m; c++) {
                    double v = 0.0;
                    for (Py_ssize_t i = 0; i < nx; i++) {
                        v += g[i] * X_u[i * m + c];
                    }
                    sq += v * v;
                    hu += v * p->u[c];
                }
                for (Py_ssize_t i = 0; i < nx; i++) {
                    gx0 += g[i] * x0[i];
                    for (Py_ssize_t t = 0; t < pdim; t++) {
                        hw[t] += g[i] * X_w[i * pdim + t];
                    }
                }
                double norm = sqrt(sq + hw[0] * hw[0] + hw[1] * hw[1]);
                if (pass == 0) {
                    largest = norm > largest ? norm : largest;
                    continue;
                }
                int constant = norm <= floor;
                norm = constant ? 1.0 : norm;
                for (Py_ssize_t t = 0; t < pdim; t++) {
                    a[rows * pdim + t] = constant ? 0.0 : hw[t] / norm;
                }
                h[rows] = (p->ineq_rhs[row] - gx0 - hu) / norm;
                mo[rows] = p->motion[row];
                if (pdim == 0 && !(mo[rows] ? h[rows] > p->domain_tolerance : h[rows] >= -p->domain_tolerance)) {
                    return -1;
                }
                rows++;
            }
        }
    }
    return rows;
}

/* x = X_u u + X_w w + x_0 (X_w (nx, pdim)), its equality residual and inequality violation. */
static void finish(const Problem *p, const long long *letters, const Scratch *s, const double *X_u,
                   const double *x0, const double *X_w, Py_ssize_t pdim, const double *w, double *x,
                   double *residual, double *violation) {
    Py_ssize_t nx = p->nx, m = p->m;
    for (Py_ssize_t i = 0; i < nx; i++) {
        double v = 0.0;
        for (Py_ssize_t c = 0; c < m; c++) {
            v += X_u[i * m + c] * p->u[c];
        }
        double xw = 0.0;
        for (Py_ssize_t t = 0; t < pdim; t++) {
            xw += X_w[i * pdim + t] * w[t];
        }
        x[i] = v + xw + x0[i];
    }
    double res = 0.0, worst = 0.0;
    for (Py_ssize_t i = 0; i < nx; i++) {
        double ax = 0.0;
        for (Py_ssize_t j = 0; j < nx; j++) {
            ax += s->A[i * nx + j] * x[j];
        }
        double d = fabs(ax - s->rhs[i]);
        res = d > res ? d : res;
    }
    for (Py_ssize_t j = 0; j < p->k; j++) {
        Py_ssize_t cell = j * LETTERS + letters[j];
        for (Py_ssize_t r = 0; r < INEQUALITY_ROWS; r++) {
            Py_ssize_t row = cell * INEQUALITY_ROWS + r;
            if (!p->valid[row]) {
                continue;
            }
            double gx = 0.0;
            for (Py_ssize_t i = 0; i < nx; i++) {
                gx += p->ineq[row * nx + i] * x[i];
            }
            double bad = gx - p->ineq_rhs[row];
            worst = bad > worst ? bad : worst;
        }
    }
    *residual = res;
    *violation = worst;
}

/* One rank-deficient (or SVD-decided) mode with p <= 1. */
static signed char rank_mode(const Problem *p, const Ranked *q, Py_ssize_t mode, const double *Su, Scratch *s,
                             double *work) {
    Py_ssize_t nx = p->nx, m = p->m;
    const long long *letters = p->letters + mode * p->k;
    Py_ssize_t r = rank_of(q->s + mode * nx, nx, q->rank_tolerance), pdim = nx - r;
    if (pdim >= 2) {
        return NEEDS_PYTHON;
    }
    assemble(p, letters, Su, s);
    double *X_u = work, *x0 = X_u + nx * m, *X_w = x0 + nx, *left = X_w + nx, *a = left + m + 1;
    double *h = a + INEQUALITY_ROWS * p->k;
    unsigned char *mo = (unsigned char *)(h + INEQUALITY_ROWS * p->k);
    responses(p, q, mode, r, s, X_u, x0, X_w, left);
    if (!consistent(p, q, mode, pdim, s, left)) {
        return INADMISSIBLE;
    }
    Py_ssize_t rows = sliced_rows(p, letters, pdim, X_u, x0, X_w, a, h, mo);
    double w = 0.0;
    if (rows < 0 || (pdim == 1 && !interval(p, q, rows, a, h, mo, &w))) {
        return INADMISSIBLE;
    }
    q->w[mode] = w;
    q->outputs[mode] = pdim ? moved_by(p, q, X_w, 1) : MOVES_NONE;
    finish(p, letters, s, X_u, x0, X_w, 1, &w, p->x + mode * nx, &p->residual[mode], &p->violation[mode]);
    return pdim ? ADMISSIBLE_W : ADMISSIBLE;
}

/* A float64 buffer of ndim dimensions with any strides (match_shape). */
static int take_strided(PyObject *obj, Buffer *b, const char *name, int ndim, Py_ssize_t *shape) {
    if (PyObject_GetBuffer(obj, &b->view, PyBUF_RECORDS_RO) != 0) {
        PyErr_Clear();
        PyErr_Format(kernel_error, "kernel buffer %s: not a strided buffer", name);
        return -1;
    }
    b->held = 1;
    if (!format_is(b->view.format, 'd') || b->view.ndim != ndim) {
        PyErr_Format(kernel_error, "kernel buffer %s: %d dimensions of format %s, expected %d of float64", name,
                     b->view.ndim, b->view.format ? b->view.format : "B", ndim);
        return -1;
    }
    return match_shape(&b->view, name, ndim, shape);
}

/* take_strided for Pinocchio's arrays (Eigen matrices of doubles): 8-byte entries, no format string
 * asked (numpy builds that string anew on every request, a tenth of the buffer's cost). */
static int take_pinocchio(PyObject *obj, Buffer *b, const char *name, int ndim, Py_ssize_t *shape) {
    if (PyObject_GetBuffer(obj, &b->view, PyBUF_STRIDES) != 0) {
        PyErr_Clear();
        PyErr_Format(kernel_error, "kernel buffer %s: not a strided buffer", name);
        return -1;
    }
    b->held = 1;
    if (b->view.itemsize != (Py_ssize_t)sizeof(double) || b->view.ndim != ndim) {
        PyErr_Format(kernel_error, "kernel buffer %s: %d dimensions of %zd-byte entries, expected %d of float64",
                     name, b->view.ndim, b->view.itemsize, ndim);
        return -1;
    }
    return match_shape(&b->view, name, ndim, shape);
}

/* ------------------------------------------------------------------ arguments
 * Every exported function describes its arguments in one table (an Arg per argument, in order),
 * and parse() reads and checks them all, the one place where arguments are read: their count,
 * each buffer's format, dimensions, layout (C-contiguous, or any strides for 's'), writability and
 * shape, each number. An axis names a shared dimension (DIM_*): the first buffer with that axis
 * sets it and every later one must match; FIX(v) asks for v entries, ANY takes any. A dimension
 * that follows from others (nx = n + 2k) is set by the signature's derive, called after each
 * argument, so the first buffer that disagrees is the one named. A function then checks only what
 * a table cannot say (the values of index buffers, a relation between two dimensions read from
 * one buffer). A wrong argument raises frcontrol.errors.KernelError naming it. */

enum { ANY = -1 };
#define FIX(v) (-2 - (v)) /* an axis of v entries */
enum { DIM_N, DIM_NX, DIM_K, DIM_M, DIM_COUNT, DIM_ROWS, DIM_P, DIM_S, DIM_T, DIM_A, MAX_DIMS };
enum { WRITE = 1, OR_NONE = 2 };
#define MAX_ARGS 40

typedef struct {
    const char *name;
    char kind;           /* 'd' float64, '?' bool, 'q' int64, 'b' int8: a C-contiguous buffer; 's': a
                            float64 buffer of any strides; 'f' a number; 'i' an integer; 't' a truth
                            value; 'o' any object (read by the function) */
    signed char ndim;
    signed char axes[4]; /* per axis: a DIM_*, FIX(v) or ANY */
    unsigned char flags; /* WRITE (a writable buffer), OR_NONE (None allowed: no data) */
} Arg;

typedef struct {
    const char *function;
    int count;
    const Arg *args;
    void (*derive)(Py_ssize_t *dim); /* sets the dimensions that follow from others, or NULL */
} Signature;

/* dim[which] = value where it is not set yet and the dimensions it follows from are (ready). */
static void derive_dim(Py_ssize_t *dim, int which, int ready, Py_ssize_t value) {
    if (dim[which] < 0 && ready) {
        dim[which] = value;
    }
}

typedef struct {
    int count;                   /* the buffers to release: the arguments read so far */
    Buffer buffer[MAX_ARGS];
    void *data[MAX_ARGS];        /* a buffer's data (NULL: None, or not a buffer) */
    double number[MAX_ARGS];     /* 'f' */
    long long integer[MAX_ARGS]; /* 'i', 't' */
    Py_ssize_t dim[MAX_DIMS];    /* the shared dimensions, -1 until set */
} Args;

static int take_scalar(const Arg *spec, PyObject *obj, Args *a, int i) {
    const char *expected = NULL; /* set when obj is not what the table asks for */
    if (spec->kind == 'f') {
        a->number[i] = PyFloat_AsDouble(obj);
        expected = a->number[i] == -1.0 && PyErr_Occurred() ? "a number" : NULL;
    } else if (spec->kind == 'i') {
        a->integer[i] = PyLong_AsLongLong(obj);
        expected = a->integer[i] == -1 && PyErr_Occurred() ? "an integer" : NULL;
    } else if (spec->kind == 't') {
        a->integer[i] = PyObject_IsTrue(obj);
        expected = a->integer[i] < 0 ? "a truth value" : NULL;
    }
    if (expected != NULL) {
        PyErr_Clear();
        PyErr_Format(kernel_error, "kernel argument %s: not %s", spec->name, expected);
        return -1;
    }
    return 0;
}

static int take_arg(const Arg *spec, PyObject *obj, Args *a, int i) {
    if (spec->kind == 'f' || spec->kind == 'i' || spec->kind == 't' || spec->kind == 'o') {
        return take_scalar(spec, obj, a, i);
    }
    if ((spec->flags & OR_NONE) && obj == Py_None) {
        return 0;
    }
    Py_ssize_t shape[4] = {-1, -1, -1, -1};
    for (int d = 0; d < spec->ndim; d++) {
        int axis = spec->axes[d];
        shape[d] = axis >= 0 ? a->dim[axis] : axis == ANY ? -1 : -2 - axis;
    }
    int failed = spec->kind == 's' ? take_strided(obj, &a->buffer[i], spec->name, spec->ndim, shape)
                                   : take(obj, &a->buffer[i], spec->name, spec->kind, spec->ndim, shape,
                                          spec->flags & WRITE);
    if (failed) {
        return -1;
    }
    for (int d = 0; d < spec->ndim; d++) {
        if (spec->axes[d] >= 0) {
            a->dim[spec->axes[d]] = shape[d];
        }
    }
    a->data[i] = a->buffer[i].view.buf;
    return 0;
}

/* Read and check every argument of `sig` into a (release them with release_args, also on failure). */
static int parse(const Signature *sig, PyObject *const *args, Py_ssize_t nargs, Args *a) {
    a->count = 0;
    for (int d = 0; d < MAX_DIMS; d++) {
        a->dim[d] = -1;
    }
    if (nargs != sig->count) {
        PyErr_Format(kernel_error, "%s takes %d arguments, got %zd", sig->function, sig->count, nargs);
        return -1;
    }
    for (int i = 0; i < sig->count; i++) {
        a->buffer[i].held = 0;
        a->data[i] = NULL;
        a->count = i + 1;
        if (take_arg(&sig->args[i], args[i], a, i)) {
            return -1;
        }
        if (sig->derive != NULL) {
            sig->derive(a->dim);
        }
    }
    return 0;
}

static void release(Buffer *b, int count) {
    for (int i = 0; i < count; i++) {
        if (b[i].held) {
            PyBuffer_Release(&b[i].view);
        }
    }
}

static void release_args(Args *a) {
    release(a->buffer, a->count);
}

/* A relation a table cannot say: axis `axis` of buffer `name` must have `expected` entries. */
static int expect_dim(Py_ssize_t got, Py_ssize_t expected, const char *name, int axis) {
    if (got != expected) {
        PyErr_Format(kernel_error, "kernel buffer %s: axis %d has %zd entries, expected %zd", name, axis, got,
                     expected);
        return -1;
    }
    return 0;
}

/* The problem's 11 buffers, the first arguments of certified_modes and rank_modes. */
#define PROBLEM_ARGS 11
#define PROBLEM_TABLE                                                                                         \
    {"dynamics", 'd', 2, {DIM_N, DIM_NX}, 0},                                                                 \
    {"equalities", 'd', 4, {DIM_K, FIX(LETTERS), FIX(EQUALITY_ROWS), DIM_NX}, 0},                            \
    {"equality_rhs", 'd', 3, {DIM_K, FIX(LETTERS), FIX(EQUALITY_ROWS)}, 0},                                   \
    {"inequalities", 'd', 4, {DIM_K, FIX(LETTERS), FIX(INEQUALITY_ROWS), DIM_NX}, 0},                        \
    {"inequality_rhs", 'd', 3, {DIM_K, FIX(LETTERS), FIX(INEQUALITY_ROWS)}, 0},                               \
    {"valid", '?', 3, {DIM_K, FIX(LETTERS), FIX(INEQUALITY_ROWS)}, 0},                                        \
    {"motion", '?', 3, {DIM_K, FIX(LETTERS), FIX(INEQUALITY_ROWS)}, 0},                                       \
    {"letters", 'q', 2, {DIM_COUNT, DIM_K}, 0},                                                               \
    {"input_map", 'd', 2, {DIM_N, DIM_M}, 0},                                                                 \
    {"bias", 'd', 1, {DIM_N}, 0},                                                                             \
    {"u", 'd', 1, {DIM_M}, 0}

/* The problem from its parsed buffers: n, nx, k, m and the mode count, nx = n + 2k, the letters. */
static int problem_from(const Args *a, Problem *p) {
    Py_ssize_t n = a->dim[DIM_N], k = a->dim[DIM_K], count = a->dim[DIM_COUNT];
    if (a->dim[DIM_NX] != n + 2 * k) {
        PyErr_Format(kernel_error, "kernel buffer dynamics: %zd columns, expected n + 2k = %zd", a->dim[DIM_NX],
                     n + 2 * k);
        return -1;
    }
    memset(p, 0, sizeof(*p));
    p->n = n, p->k = k, p->m = a->dim[DIM_M], p->nx = a->dim[DIM_NX], p->count = count;
    p->dynamics = a->data[0], p->eq = a->data[1], p->eq_rhs = a->data[2];
    p->ineq = a->data[3], p->ineq_rhs = a->data[4];
    p->valid = a->data[5], p->motion = a->data[6], p->letters = a->data[7];
    p->input_map = a->data[8], p->bias = a->data[9], p->u = a->data[10];
    for (Py_ssize_t i = 0; i < count * k; i++) {
        if (p->letters[i] < 0 || p->letters[i] >= LETTERS) {
            PyErr_Format(kernel_error, "kernel buffer letters: entry %lld is not a letter index 0-3",
                         p->letters[i]);
            return -1;
        }
    }
    return 0;
}

/* Scratch for one mode at a time, and S^T u. */
static double *scratch(const Problem *p, Scratch *s, double **Su, double **work) {
    Py_ssize_t nx = p->nx, m = p->m, w = nx + m + 1;
    Py_ssize_t size = 3 * nx * nx + nx * w + 6 * nx + nx * m + p->n + 1;
    size += nx * m + 3 * nx + m + 1 + 3 * INEQUALITY_ROWS * p->k + 1; /* rank_mode's work */
    double *memory = PyMem_Malloc((size_t)size * sizeof(double));
    if (memory == NULL) {
        PyErr_NoMemory();
        return NULL;
    }
    double *at = memory;
    s->A = at, at += nx * nx;
    s->A_hat = at, at += nx * nx;
    s->Y = at, at += nx * w + nx * nx;
    s->rhs = at, at += nx;
    s->c = at, at += nx;
    s->r_scale = at, at += nx;
    s->c_scale = at, at += nx;
    s->xs = at, at += nx;
    s->X_u = at, at += nx * m;
    *Su = at, at += p->n + 1;
    *work = at;
    for (Py_ssize_t i = 0; i < p->n; i++) {
        double v = 0.0;
        for (Py_ssize_t j = 0; j < m; j++) {
            v += p->input_map[i * m + j] * p->u[j];
        }
        (*Su)[i] = v;
    }
    return memory;
}

static const Arg certified_table[] = {
    PROBLEM_TABLE,
    {"status", 'b', 1, {DIM_COUNT}, WRITE}, {"x", 'd', 2, {DIM_COUNT, DIM_NX}, WRITE},
    {"residual", 'd', 1, {DIM_COUNT}, WRITE}, {"violation", 'd', 1, {DIM_COUNT}, WRITE},
    {"a_hat", 'd', 3, {DIM_COUNT, DIM_NX, DIM_NX}, WRITE}, {"r_scale", 'd', 2, {DIM_COUNT, DIM_NX}, WRITE},
    {"c_scale", 'd', 2, {DIM_COUNT, DIM_NX}, WRITE},
    {"margin", 'f', 0, {0}, 0}, {"tolerance", 'f', 0, {0}, 0}, {"domain_tolerance", 'f', 0, {0}, 0},
    {"zero_row_tolerance", 'f', 0, {0}, 0}};
static const Signature certified_signature = {"certified_modes", 22, certified_table, NULL};

static PyObject *certified_modes(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    Problem p;
    PyObject *result = NULL;
    double *memory = NULL, *Su, *work;
    if (parse(&certified_signature, args, nargs, &a) || problem_from(&a, &p)) {
        goto done;
    }
    void *const *out = a.data + PROBLEM_ARGS;
    const double *number = a.number + PROBLEM_ARGS + 7;
    p.status = out[0], p.x = out[1], p.residual = out[2], p.violation = out[3];
    p.a_hat_out = out[4], p.r_out = out[5], p.c_out = out[6];
    p.margin = number[0], p.tolerance = number[1], p.domain_tolerance = number[2], p.zero_row_tolerance = number[3];
    Scratch s;
    memory = scratch(&p, &s, &Su, &work);
    if (memory == NULL) {
        goto done;
    }
    run_modes(&p, Su, &s);
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(memory);
    release_args(&a);
    return result;
}

static const Arg rank_table[] = {
    PROBLEM_TABLE,
    {"U", 'd', 3, {DIM_COUNT, DIM_NX, DIM_NX}, 0}, {"s", 'd', 2, {DIM_COUNT, DIM_NX}, 0},
    {"Vt", 'd', 3, {DIM_COUNT, DIM_NX, DIM_NX}, 0}, {"r_scale", 'd', 2, {DIM_COUNT, DIM_NX}, 0},
    {"c_scale", 'd', 2, {DIM_COUNT, DIM_NX}, 0},
    {"status", 'b', 1, {DIM_COUNT}, WRITE}, {"x", 'd', 2, {DIM_COUNT, DIM_NX}, WRITE},
    {"w", 'd', 1, {DIM_COUNT}, WRITE}, {"outputs", 'b', 1, {DIM_COUNT}, WRITE},
    {"residual", 'd', 1, {DIM_COUNT}, WRITE}, {"violation", 'd', 1, {DIM_COUNT}, WRITE},
    {"rank_tolerance", 'f', 0, {0}, 0}, {"band", 'f', 0, {0}, 0}, {"domain_tolerance", 'f', 0, {0}, 0},
    {"zero_row_tolerance", 'f', 0, {0}, 0}, {"radius_cap", 'f', 0, {0}, 0},
    {"consistency_tolerance", 'f', 0, {0}, 0}, {"output_tolerance", 'f', 0, {0}, 0}};
static const Signature rank_signature = {"rank_modes", 29, rank_table, NULL};

/* Whether a singular value of some mode lies in the ill-conditioned band (then nothing is decided). */
static int in_band(const Problem *p, const Ranked *q) {
    for (Py_ssize_t mode = 0; mode < p->count; mode++) {
        const double *sv = q->s + mode * p->nx;
        for (Py_ssize_t i = 0; i < p->nx; i++) {
            if (sv[i] > q->rank_tolerance * sv[0] && sv[i] <= q->band * sv[0]) {
                return 1;
            }
        }
    }
    return 0;
}

static PyObject *rank_modes(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    Problem p;
    Ranked q;
    PyObject *result = NULL;
    double *memory = NULL, *Su, *work;
    if (parse(&rank_signature, args, nargs, &a) || problem_from(&a, &p)) {
        goto done;
    }
    void *const *io = a.data + PROBLEM_ARGS;
    const double *number = a.number + PROBLEM_ARGS + 11;
    q.U = io[0], q.s = io[1], q.Vt = io[2], q.r_in = io[3], q.c_in = io[4];
    p.status = io[5], p.x = io[6], q.w = io[7], q.outputs = io[8], p.residual = io[9], p.violation = io[10];
    q.rank_tolerance = number[0], q.band = number[1], p.domain_tolerance = number[2];
    p.zero_row_tolerance = number[3], q.radius_cap = number[4], q.consistency_tolerance = number[5];
    q.output_tolerance = number[6];
    if (in_band(&p, &q)) {
        result = Py_NewRef(Py_True);
        goto done;
    }
    Scratch s;
    memory = scratch(&p, &s, &Su, &work);
    if (memory == NULL) {
        goto done;
    }
    Py_ssize_t nx = p.nx;
    for (Py_ssize_t mode = 0; mode < p.count; mode++) {
        memset(p.x + mode * nx, 0, (size_t)nx * sizeof(double));
        q.w[mode] = p.residual[mode] = p.violation[mode] = 0.0;
        q.outputs[mode] = MOVES_NONE;
        p.status[mode] = rank_mode(&p, &q, mode, Su, &s, work);
    }
    result = Py_NewRef(Py_False);
done:
    PyMem_Free(memory);
    release_args(&a);
    return result;
}

/* The LP door's check of an answer (frcontrol.solvers.primal_residual and _residual_tolerance):
 * residual = max(0, max(A_ub x - b_ub), max |A_eq x - b_eq|, max(lb - x), max(x - ub)) (the
 * bounds only when has_bounds), and scale = 1 + the largest finite |b_ub|, |b_eq| (|lb|, |ub| when
 * has_bounds) + (max_i ||a_ub_i||_1 + max_j ||a_eq_j||_1) ||x||_inf, the last term added row block by
 * row block as there. x None: no residual (NaN) and no x term. */
static double row_block_residual(const double *A, const double *b, const double *x, Py_ssize_t rows,
                                 Py_ssize_t n, int absolute, double worst) {
    for (Py_ssize_t i = 0; i < rows; i++) {
        double v = 0.0;
        for (Py_ssize_t j = 0; j < n; j++) {
            v += A[i * n + j] * x[j];
        }
        v -= b[i];
        if (absolute) {
            v = fabs(v);
        }
        if (v > worst) {
            worst = v;
        }
    }
    return worst;
}

static double largest_row_l1(const double *A, Py_ssize_t rows, Py_ssize_t n) {
    double best = 0.0;
    for (Py_ssize_t i = 0; i < rows; i++) {
        double v = 0.0;
        for (Py_ssize_t j = 0; j < n; j++) {
            v += fabs(A[i * n + j]);
        }
        if (v > best) {
            best = v;
        }
    }
    return best;
}

static double largest_finite(const double *v, Py_ssize_t size, double best) {
    for (Py_ssize_t i = 0; i < size; i++) {
        double a = fabs(v[i]);
        if (a < HUGE_VAL && a > best) {
            best = a;
        }
    }
    return best;
}

static const Arg lp_table[] = {
    {"A_ub", 'd', 2, {DIM_M, DIM_N}, 0}, {"b_ub", 'd', 1, {DIM_M}, 0}, {"A_eq", 'd', 2, {DIM_K, DIM_N}, 0},
    {"b_eq", 'd', 1, {DIM_K}, 0}, {"lb", 'd', 1, {DIM_N}, 0}, {"ub", 'd', 1, {DIM_N}, 0},
    {"x", 'd', 1, {DIM_N}, OR_NONE}, {"has_bounds", 't', 0, {0}, 0}};
static const Signature lp_signature = {"lp_check", 8, lp_table, NULL};

static PyObject *lp_check(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    if (parse(&lp_signature, args, nargs, &a)) {
        goto done;
    }
    Py_ssize_t n = a.dim[DIM_N], m_ub = a.dim[DIM_M], m_eq = a.dim[DIM_K];
    int has_x = args[6] != Py_None, has_bounds = (int)a.integer[7];
    const double *A_ub = a.data[0], *b_ub = a.data[1], *A_eq = a.data[2], *b_eq = a.data[3];
    const double *lb = a.data[4], *ub = a.data[5], *x = a.data[6];
    double top = largest_finite(b_eq, m_eq, largest_finite(b_ub, m_ub, 0.0));
    if (has_bounds) {
        top = largest_finite(ub, n, largest_finite(lb, n, top));
    }
    double scale = 1.0 + top, residual = NAN;
    if (has_x) {
        double size = 0.0;
        residual = 0.0;
        for (Py_ssize_t j = 0; j < n; j++) {
            size = fabs(x[j]) > size ? fabs(x[j]) : size;
            if (has_bounds) {
                residual = lb[j] - x[j] > residual ? lb[j] - x[j] : residual;
                residual = x[j] - ub[j] > residual ? x[j] - ub[j] : residual;
            }
        }
        residual = row_block_residual(A_ub, b_ub, x, m_ub, n, 0, residual);
        residual = row_block_residual(A_eq, b_eq, x, m_eq, n, 1, residual);
        if (m_ub && n) {
            scale += largest_row_l1(A_ub, m_ub, n) * size;
        }
        if (m_eq && n) {
            scale += largest_row_l1(A_eq, m_eq, n) * size;
        }
    }
    result = Py_BuildValue("(dd)", residual, scale);
done:
    release_args(&a);
    return result;
}

/* ------------------------------------------------------------------------------------------------
 * robot_state: frcontrol.model.PlanarRobot.state after Pinocchio's computeAllTerms, in one call.
 * Its NumPy path (PlanarRobot._state_numpy) is the reference it reproduces. Per contact frame, in
 * that order, it calls Pinocchio's updateFramePlacement (the position p), getFrameJacobian (J,
 * 6 x nv, world-aligned, at the point) and getFrameClassicalAcceleration (a, the drift), the calls
 * the NumPy path makes. Pinocchio's M, nle and each frame's p are read through views of the
 * data's own storage (data.M, data.nle, data.oMf[frame].translation: the plan's and the
 * positions' arrays, made once), which computeAllTerms and updateFramePlacement overwrite in
 * place: reading them costs no conversion per call. Then, with the contact's normal n, tangent
 * t and offset n . s of its line: the point p[0:2], the gap n . p[0:2] - n . s, the rows
 * J_N = n^T J[0:2] and J_T = t^T J[0:2] in minimal order, the velocities J_N v and J_T v, the
 * drifts n . a[0:2] and t . a[0:2]. M is mirrored from CRBA's upper triangle and h = nle (+ b v,
 * the drives' damping), both in minimal order. Pinocchio's arrays may be strided (Eigen is
 * column-major). The result is a new instance of the state type with every field in its
 * __dict__, as its __init__ would set them; its arrays are new: the points, and views of two new
 * blocks, [M; J_N; J_T] (n + 2k, n) and [h, gaps, v_N, v_T, drift_N, drift_T] (n + 5k,). The
 * frames must be the model's (PlanarRobot's layouts): Pinocchio does not check a frame index.
 */
#define STATE_FIELDS 12
#define STATE_ARGS 7
#define PLAN_ENTRIES 12
#define LINE_ENTRIES 5 /* n_x, n_y, t_x, t_y, n . s */

static const char *state_field_names[STATE_FIELDS] = {
    "q", "v", "mass_matrix", "bias", "contact_points", "gaps", "normal_velocities",
    "tangential_velocities", "jacobian_normal", "jacobian_tangent", "drift_normal", "drift_tangent"};
static PyObject *state_fields[STATE_FIELDS]; /* interned on the first call */
static PyObject *vector_name;
enum { F_MASS = 2, F_BIAS, F_POINTS, F_GAPS, F_VN, F_VT, F_JN, F_JT, F_DN, F_DT };
enum { P_TYPE, P_EMPTY, P_MODEL, P_DATA, P_UPDATE, P_JACOBIAN, P_ACCELERATION, P_FRAME, P_V_INDEX, P_NV, P_MASS,
       P_NLE };
enum { A_PLAN, A_Q, A_V, A_FRAMES, A_POSITIONS, A_LINES, A_DAMPING };

static double at1(const Py_buffer *v, Py_ssize_t i) {
    return *(const double *)((const char *)v->buf + i * v->strides[0]);
}

static double at2(const Py_buffer *v, Py_ssize_t i, Py_ssize_t j) {
    return *(const double *)((const char *)v->buf + i * v->strides[0] + j * v->strides[1]);
}

/* A new float64 array (rows,) or (rows, cols) from `empty` (numpy.empty, whose default type is
 * float64), its C-contiguous buffer held in b (no format asked: numpy builds that string anew for
 * every new array). */
static PyObject *new_array(PyObject *empty, Py_ssize_t rows, Py_ssize_t cols, Buffer *b, double **data) {
    PyObject *shape = cols < 0 ? PyLong_FromSsize_t(rows) : PyTuple_New(2);
    if (shape != NULL && cols >= 0) {
        PyObject *r = PyLong_FromSsize_t(rows), *c = PyLong_FromSsize_t(cols);
        PyTuple_SET_ITEM(shape, 0, r);
        PyTuple_SET_ITEM(shape, 1, c);
        if (r == NULL || c == NULL) {
            Py_CLEAR(shape);
        }
    }
    if (shape == NULL) {
        return NULL;
    }
    PyObject *array = PyObject_CallOneArg(empty, shape);
    Py_DECREF(shape);
    if (array == NULL) {
        return NULL;
    }
    Py_ssize_t size = cols < 0 ? rows : rows * cols;
    if (PyObject_GetBuffer(array, &b->view, PyBUF_C_CONTIGUOUS | PyBUF_WRITABLE) != 0 ||
        (b->held = 1, b->view.len != size * (Py_ssize_t)sizeof(double))) {
        PyErr_Clear();
        PyErr_Format(kernel_error, "kernel buffer output: not %zd writable, C-contiguous float64 entries", size);
        Py_DECREF(array);
        return NULL;
    }
    *data = b->view.buf;
    return array;
}

typedef struct {
    Py_ssize_t n, nv, k;
    PyObject *const *plan;
    const long long *v_index; /* NULL: the identity */
    const double *damping;    /* NULL: none */
    double *lines;            /* (k, LINE_ENTRIES), read from the tuple of floats */
    const Py_buffer *v;       /* (n,), any stride */
    double *mass, *bias, *points, *rows, *values; /* values: gaps, v_N, v_T, drift_N, drift_T */
} StateJob;

static Py_ssize_t pinocchio_index(const StateJob *job, Py_ssize_t a) {
    return job->v_index ? (Py_ssize_t)job->v_index[a] : a;
}

/* M (mirrored from the upper triangle) and h in minimal order. */
static void fill_dynamics(const StateJob *job, const Py_buffer *mass, const Py_buffer *nle) {
    Py_ssize_t n = job->n;
    for (Py_ssize_t a = 0; a < n; a++) {
        Py_ssize_t ia = pinocchio_index(job, a);
        for (Py_ssize_t c = 0; c < n; c++) {
            Py_ssize_t ic = pinocchio_index(job, c);
            job->mass[a * n + c] = ia <= ic ? at2(mass, ia, ic) : at2(mass, ic, ia);
        }
        job->bias[a] = at1(nle, ia);
        if (job->damping) {
            job->bias[a] = job->bias[a] + job->damping[a] * at1(job->v, a);
        }
    }
}

/* Contact i's entries from its frame's position, Jacobian and classical acceleration. */
static void fill_contact(const StateJob *job, Py_ssize_t i, const Py_buffer *pos, const Py_buffer *J,
                         const Py_buffer *acc) {
    Py_ssize_t n = job->n, k = job->k;
    const double *line = job->lines + LINE_ENTRIES * i;
    double *JN = job->rows + i * n, *JT = job->rows + (k + i) * n, vn = 0.0, vt = 0.0;
    for (Py_ssize_t a = 0; a < n; a++) {
        Py_ssize_t col = pinocchio_index(job, a);
        double jx = at2(J, 0, col), jy = at2(J, 1, col);
        JN[a] = line[0] * jx + line[1] * jy;
        JT[a] = line[2] * jx + line[3] * jy;
        vn += JN[a] * at1(job->v, a);
        vt += JT[a] * at1(job->v, a);
    }
    double px = at1(pos, 0), py = at1(pos, 1), ax = at1(acc, 0), ay = at1(acc, 1);
    job->points[2 * i] = px;
    job->points[2 * i + 1] = py;
    job->values[i] = line[0] * px + line[1] * py - line[4];
    job->values[k + i] = vn;
    job->values[2 * k + i] = vt;
    job->values[3 * k + i] = line[0] * ax + line[1] * ay;
    job->values[4 * k + i] = line[2] * ax + line[3] * ay;
}

/* Pinocchio's call `function(model, data, frame[, reference frame])`, then its attribute `name`
 * (NULL: the result itself). */
static PyObject *pinocchio_call(const StateJob *job, int function, PyObject *frame, int world_aligned,
                                PyObject *name) {
    PyObject *call_args[4] = {job->plan[P_MODEL], job->plan[P_DATA], frame, job->plan[P_FRAME]};
    PyObject *result = PyObject_Vectorcall(job->plan[function], call_args, world_aligned ? 4 : 3, NULL);
    if (result == NULL || name == NULL) {
        return result;
    }
    PyObject *attribute = PyObject_GetAttr(result, name);
    Py_DECREF(result);
    return attribute;
}

/* Every contact frame of the tuple `frames`: Pinocchio's three calls, then its entries; the
 * frame's position is read from its view in the tuple `positions` after updateFramePlacement. */
static int fill_contacts(const StateJob *job, PyObject *frames, PyObject *positions) {
    for (Py_ssize_t i = 0; i < job->k; i++) {
        PyObject *frame = PyTuple_GET_ITEM(frames, i), *arrays[3];
        PyObject *placement = pinocchio_call(job, P_UPDATE, frame, 0, NULL);
        Py_XDECREF(placement);
        arrays[0] = placement ? Py_NewRef(PyTuple_GET_ITEM(positions, i)) : NULL;
        arrays[1] = arrays[0] ? pinocchio_call(job, P_JACOBIAN, frame, 1, NULL) : NULL;
        arrays[2] = arrays[1] ? pinocchio_call(job, P_ACCELERATION, frame, 1, vector_name) : NULL;
        Buffer fb[3];
        memset(fb, 0, sizeof(fb));
        Py_ssize_t pos_shape[1] = {3}, jac_shape[2] = {6, job->nv}, acc_shape[1] = {6};
        int failed = arrays[2] == NULL || take_pinocchio(arrays[0], &fb[0], "position", 1, pos_shape) ||
                     take_pinocchio(arrays[1], &fb[1], "jacobian", 2, jac_shape) ||
                     take_pinocchio(arrays[2], &fb[2], "acceleration", 1, acc_shape);
        if (!failed) {
            fill_contact(job, i, &fb[0].view, &fb[1].view, &fb[2].view);
        }
        release(fb, 3);
        for (int a = 0; a < 3; a++) {
            Py_XDECREF(arrays[a]);
        }
        if (failed) {
            return -1;
        }
    }
    return 0;
}

static int intern_names(void) {
    for (int f = 0; f < STATE_FIELDS; f++) {
        if (state_fields[f] == NULL && (state_fields[f] = PyUnicode_InternFromString(state_field_names[f])) == NULL) {
            return -1;
        }
    }
    if (vector_name == NULL && (vector_name = PyUnicode_InternFromString("vector")) == NULL) {
        return -1;
    }
    return 0;
}

/* object.__new__(state_type) with the fields `values` set as object.__setattr__ sets them (the
 * frozen class's own __setattr__ refuses), into the instance's __dict__. */
static PyObject *new_state(PyObject *state_type, PyObject **values) {
    PyObject *no_args = PyTuple_New(0), *state = NULL;
    if (no_args != NULL) {
        state = PyBaseObject_Type.tp_new((PyTypeObject *)state_type, no_args, NULL);
        Py_DECREF(no_args);
    }
    for (int f = 0; f < STATE_FIELDS && state != NULL; f++) {
        if (PyObject_GenericSetAttr(state, state_fields[f], values[f]) != 0) {
            Py_CLEAR(state);
        }
    }
    return state;
}

static const Arg state_table[STATE_ARGS] = {
    {"plan", 'o', 0, {0}, 0}, {"q", 'o', 0, {0}, 0}, {"v", 's', 1, {DIM_N}, 0}, {"frames", 'o', 0, {0}, 0},
    {"positions", 'o', 0, {0}, 0}, {"lines", 'o', 0, {0}, 0}, {"damping", 'd', 1, {DIM_N}, OR_NONE}};
static const Signature state_signature = {"robot_state", STATE_ARGS, state_table, NULL};

/* The lines' floats (k, LINE_ENTRIES) into job->lines (freed by the caller). */
static int take_lines(PyObject *lines, StateJob *job) {
    if (!PyTuple_Check(lines) || PyTuple_GET_SIZE(lines) != LINE_ENTRIES * job->k) {
        PyErr_Format(kernel_error, "robot_state: lines must be a tuple of %zd floats", LINE_ENTRIES * job->k);
        return -1;
    }
    job->lines = PyMem_Malloc((size_t)(LINE_ENTRIES * job->k + 1) * sizeof(double));
    if (job->lines == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    for (Py_ssize_t i = 0; i < LINE_ENTRIES * job->k; i++) {
        job->lines[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(lines, i));
        if (job->lines[i] == -1.0 && PyErr_Occurred()) {
            PyErr_Clear();
            PyErr_Format(kernel_error, "robot_state: lines[%zd] is not a number", i);
            return -1;
        }
    }
    return 0;
}

/* The robot's plan (its mass, nle and v_index buffers into b), the frames' count k and n into job. */
static int take_robot(PyObject *plan, PyObject *frames, PyObject *positions, Py_ssize_t n, Buffer *b,
                      StateJob *job) {
    if (!PyTuple_Check(plan) || PyTuple_GET_SIZE(plan) != PLAN_ENTRIES || !PyType_Check(PyTuple_GET_ITEM(plan, P_TYPE)) ||
        !PyTuple_Check(frames) || !PyTuple_Check(positions) ||
        PyTuple_GET_SIZE(positions) != PyTuple_GET_SIZE(frames)) {
        PyErr_Format(kernel_error, "robot_state: plan must be a tuple of %d entries, the first a class, and "
                     "frames and positions tuples of one length", PLAN_ENTRIES);
        return -1;
    }
    job->plan = &PyTuple_GET_ITEM(plan, 0);
    job->nv = PyLong_AsSsize_t(job->plan[P_NV]);
    if (job->nv < 0) {
        if (!PyErr_Occurred()) {
            PyErr_SetString(kernel_error, "robot_state: nv must be >= 0");
        }
        return -1;
    }
    Py_ssize_t nv = job->nv, mass_shape[2] = {nv, nv}, nle_shape[1] = {nv};
    job->k = PyTuple_GET_SIZE(frames);
    job->n = n;
    if (take_pinocchio(job->plan[P_MASS], &b[0], "mass", 2, mass_shape) ||
        take_pinocchio(job->plan[P_NLE], &b[1], "nle", 1, nle_shape)) {
        return -1;
    }
    Py_ssize_t n_shape[1] = {job->n};
    if (job->plan[P_V_INDEX] == Py_None) {
        if (job->n != nv) {
            PyErr_Format(kernel_error, "robot_state: v has %zd entries, expected %zd", job->n, nv);
            return -1;
        }
        return 0;
    }
    if (take(job->plan[P_V_INDEX], &b[2], "v_index", 'q', 1, n_shape, 0)) {
        return -1;
    }
    job->v_index = b[2].view.buf;
    for (Py_ssize_t i = 0; i < job->n; i++) {
        if (job->v_index[i] < 0 || job->v_index[i] >= nv) {
            PyErr_Format(kernel_error, "robot_state: v_index[%zd] = %lld is outside 0..%zd", i,
                         job->v_index[i], nv - 1);
            return -1;
        }
    }
    return 0;
}

/* The plan's entries and the parsed arguments into job (take_robot, then v, the damping, the lines). */
static int take_plan(PyObject *const *args, const Args *a, Buffer *b, StateJob *job) {
    if (take_robot(args[A_PLAN], args[A_FRAMES], args[A_POSITIONS], a->dim[DIM_N], b, job)) {
        return -1;
    }
    job->v = &a->buffer[A_V].view, job->damping = a->data[A_DAMPING];
    return take_lines(args[A_LINES], job);
}

#define STATE_VIEWS 9
static Py_ssize_t views_n = -1, views_k = -1; /* the (n, k) of view_slices */
static PyObject *view_slices[STATE_VIEWS];   /* the views' slices of the blocks, for that (n, k) */

/* The slices of state_arrays' views for (n, k), made when (n, k) differs from the last call's (a
 * slice made per view costs a fifth of the view). */
static int state_slices(Py_ssize_t n, Py_ssize_t k) {
    if (n == views_n && k == views_k) {
        return 0;
    }
    views_n = views_k = -1;
    for (int j = 0; j < STATE_VIEWS; j++) {
        Py_ssize_t lo = j == 0 || j == 3 ? 0 : j < 3 ? n + (j - 1) * k : n + (j - 4) * k;
        Py_ssize_t hi = j == 0 || j == 3 ? n : lo + k;
        PyObject *start = PyLong_FromSsize_t(lo), *stop = PyLong_FromSsize_t(hi);
        PyObject *slice = start && stop ? PySlice_New(start, stop, NULL) : NULL;
        Py_XDECREF(start);
        Py_XDECREF(stop);
        if (slice == NULL) {
            return -1;
        }
        Py_XSETREF(view_slices[j], slice);
    }
    views_n = n, views_k = k;
    return 0;
}

/* The state's arrays, new: the points, and views of two new blocks, the (n + 2k, n) matrices
 * [M; J_N; J_T] and the (n + 5k,) vectors [h, gaps, v_N, v_T, drift_N, drift_T] (three arrays
 * from numpy.empty instead of ten: a view costs less than an array and its buffer). */
static int state_arrays(StateJob *job, PyObject *empty, PyObject **values, Buffer *out) {
    Py_ssize_t n = job->n, k = job->k;
    double *matrices = NULL, *vectors = NULL;
    PyObject *blocks[2] = {new_array(empty, n + 2 * k, n, &out[0], &matrices), NULL};
    blocks[1] = blocks[0] ? new_array(empty, n + 5 * k, -1, &out[1], &vectors) : NULL;
    int failed = blocks[1] == NULL ||
                 (values[F_POINTS] = new_array(empty, k, 2, &out[2], &job->points)) == NULL || state_slices(n, k);
    int views[STATE_VIEWS] = {F_MASS, F_JN, F_JT, F_BIAS, F_GAPS, F_VN, F_VT, F_DN, F_DT}; /* 3 of one, 6 of the other */
    for (int j = 0; j < STATE_VIEWS && !failed; j++) {
        failed = (values[views[j]] = PyObject_GetItem(blocks[j >= 3], view_slices[j])) == NULL;
    }
    Py_XDECREF(blocks[0]);
    Py_XDECREF(blocks[1]);
    if (!failed) {
        job->mass = matrices, job->rows = matrices + n * n, job->bias = vectors, job->values = vectors + n;
    }
    return failed ? -1 : 0;
}

static PyObject *robot_state(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (intern_names()) {
        return NULL;
    }
    Args a;
    Buffer b[3], out[3]; /* the plan's mass, nle and v_index; the three new arrays */
    memset(b, 0, sizeof(b));
    memset(out, 0, sizeof(out));
    StateJob job;
    memset(&job, 0, sizeof(job));
    PyObject *values[STATE_FIELDS] = {NULL}, *result = NULL;
    if (parse(&state_signature, args, nargs, &a) == 0 && take_plan(args, &a, b, &job) == 0 &&
        state_arrays(&job, job.plan[P_EMPTY], values, out) == 0) {
        fill_dynamics(&job, &b[0].view, &b[1].view);
        if (fill_contacts(&job, args[A_FRAMES], args[A_POSITIONS]) == 0) {
            values[0] = args[A_Q];
            values[1] = args[A_V];
            result = new_state(job.plan[P_TYPE], values);
        }
    }
    PyMem_Free(job.lines);
    release_args(&a);
    release(b, 3);
    release(out, 3);
    for (int f = F_MASS; f < STATE_FIELDS; f++) {
        Py_XDECREF(values[f]);
    }
    return result;
}

/* ------------------------------------------------------------------------------------------------
 * contact_rows: the dynamics rows and the contact row table of frcontrol.modes (dynamics_rows and
 * contact_row_table, the reference), written into given arrays for the mode batch. Every entry is
 * one of the problem's numbers, its negative, -max(1, mu), 0, 1 or -1, as in the table of
 * frcontrol.modes.ContactRowTable's docstring: the arrays equal the reference's bit for bit.
 */
#define ROW_LETTERS 4 /* S, L, R, F */
enum { LETTER_S, LETTER_L, LETTER_R, LETTER_F };

typedef struct {
    Py_ssize_t n, k, nx;
    const Py_buffer *mass, *jn, *jt, *dn, *dt, *mu, *vn, *vt;
    double tolerance;
    double *dynamics, *eq, *eq_rhs, *ineq, *ineq_rhs;
    unsigned char *valid, *motion;
} RowJob;

/* Contact i's rows: equalities (ROW_LETTERS, 2, nx), inequalities (ROW_LETTERS, 3, nx). */
static void contact_rows_of(const RowJob *r, Py_ssize_t i) {
    Py_ssize_t n = r->n, k = r->k, nx = r->nx, lam_n = n + i, lam_t = n + k + i;
    double *eq = r->eq + i * ROW_LETTERS * EQUALITY_ROWS * nx, *eq_rhs = r->eq_rhs + i * ROW_LETTERS * EQUALITY_ROWS;
    double *in = r->ineq + i * ROW_LETTERS * INEQUALITY_ROWS * nx;
    double *in_rhs = r->ineq_rhs + i * ROW_LETTERS * INEQUALITY_ROWS;
    unsigned char *valid = r->valid + i * ROW_LETTERS * INEQUALITY_ROWS;
    unsigned char *motion = r->motion + i * ROW_LETTERS * INEQUALITY_ROWS;
    double mu = at1(r->mu, i), dn = at1(r->dn, i), dt = at1(r->dt, i);
    double scale = -(1.0 > mu ? 1.0 : mu); /* -max(1, mu), as np.maximum(1.0, mu) then negated */
    int resting = fabs(at1(r->vn, i)) <= r->tolerance, sticking = fabs(at1(r->vt, i)) <= r->tolerance;
#define EQ(letter, row, col) eq[((letter) * EQUALITY_ROWS + (row)) * nx + (col)]
#define IN(letter, row, col) in[((letter) * INEQUALITY_ROWS + (row)) * nx + (col)]
#define CELL(letter, row) ((letter) * INEQUALITY_ROWS + (row))
    EQ(LETTER_S, 0, lam_n) = 1.0; /* S: lam_N = 0, lam_T = 0 */
    EQ(LETTER_S, 1, lam_t) = 1.0;
    for (Py_ssize_t c = 0; c < n; c++) {
        double jn = at2(r->jn, i, c), jt = at2(r->jt, i, c);
        for (int letter = LETTER_L; letter <= LETTER_F; letter++) {
            EQ(letter, 0, c) = jn; /* a_N = 0 in L, R, F */
        }
        EQ(LETTER_F, 1, c) = jt; /* F: a_T = 0 */
        IN(LETTER_S, 0, c) = -jn; /* S: a_N >= 0 */
        IN(LETTER_R, 1, c) = -jt; /* R: a_T >= 0 */
        IN(LETTER_L, 1, c) = jt;  /* L: a_T <= 0 */
    }
    for (int letter = LETTER_L; letter <= LETTER_F; letter++) {
        eq_rhs[letter * EQUALITY_ROWS] = -dn;
    }
    eq_rhs[LETTER_F * EQUALITY_ROWS + 1] = -dt;
    EQ(LETTER_R, 1, lam_t) = 1.0; /* R: lam_T + mu lam_N = 0 */
    EQ(LETTER_R, 1, lam_n) = mu;
    EQ(LETTER_L, 1, lam_t) = 1.0; /* L: lam_T - mu lam_N = 0 */
    EQ(LETTER_L, 1, lam_n) = -mu;
    in_rhs[CELL(LETTER_S, 0)] = dn;
    IN(LETTER_L, 0, lam_n) = IN(LETTER_R, 0, lam_n) = scale; /* L, R: -max(1, mu) lam_N <= 0 */
    IN(LETTER_F, 0, lam_n) = -1.0;                            /* F: lam_N >= 0 */
    in_rhs[CELL(LETTER_R, 1)] = dt;
    in_rhs[CELL(LETTER_L, 1)] = -dt;
    IN(LETTER_F, 1, lam_t) = 1.0; /* F: lam_T - mu lam_N <= 0 */
    IN(LETTER_F, 1, lam_n) = -mu;
    IN(LETTER_F, 2, lam_t) = -1.0; /* F: -lam_T - mu lam_N <= 0 */
    IN(LETTER_F, 2, lam_n) = -mu;
    valid[CELL(LETTER_S, 0)] = motion[CELL(LETTER_S, 0)] = (unsigned char)resting;
    valid[CELL(LETTER_L, 0)] = valid[CELL(LETTER_R, 0)] = valid[CELL(LETTER_F, 0)] = 1;
    valid[CELL(LETTER_L, 1)] = valid[CELL(LETTER_R, 1)] = (unsigned char)sticking;
    motion[CELL(LETTER_L, 1)] = motion[CELL(LETTER_R, 1)] = (unsigned char)sticking;
    valid[CELL(LETTER_F, 1)] = valid[CELL(LETTER_F, 2)] = 1;
#undef EQ
#undef IN
#undef CELL
}

#define ROW_CELLS {DIM_K, FIX(ROW_LETTERS), FIX(INEQUALITY_ROWS)}
static const Arg rows_table[] = {
    {"mass", 's', 2, {DIM_N, DIM_S}, 0}, {"jacobian_normal", 's', 2, {DIM_K, DIM_N}, 0},
    {"jacobian_tangent", 's', 2, {DIM_K, DIM_N}, 0}, {"drift_normal", 's', 1, {DIM_K}, 0},
    {"drift_tangent", 's', 1, {DIM_K}, 0}, {"mu", 's', 1, {DIM_K}, 0}, {"normal_velocities", 's', 1, {DIM_K}, 0},
    {"tangential_velocities", 's', 1, {DIM_K}, 0}, {"velocity_tolerance", 'f', 0, {0}, 0},
    {"dynamics", 'd', 2, {DIM_N, DIM_NX}, WRITE},
    {"equalities", 'd', 4, {DIM_K, FIX(ROW_LETTERS), FIX(EQUALITY_ROWS), DIM_NX}, WRITE},
    {"equality_rhs", 'd', 3, {DIM_K, FIX(ROW_LETTERS), FIX(EQUALITY_ROWS)}, WRITE},
    {"inequalities", 'd', 4, {DIM_K, FIX(ROW_LETTERS), FIX(INEQUALITY_ROWS), DIM_NX}, WRITE},
    {"inequality_rhs", 'd', 3, ROW_CELLS, WRITE}, {"valid", '?', 3, ROW_CELLS, WRITE},
    {"motion", '?', 3, ROW_CELLS, WRITE}};
static void derive_rows(Py_ssize_t *dim) {
    derive_dim(dim, DIM_NX, dim[DIM_N] >= 0 && dim[DIM_K] >= 0, dim[DIM_N] + 2 * dim[DIM_K]);
}
static const Signature rows_signature = {"contact_rows", 16, rows_table, derive_rows};

/* The parsed arguments as a RowJob: the mass matrix square, nx = n + 2k. */
static int row_job(const Args *a, RowJob *r) {
    Py_ssize_t n = a->dim[DIM_N], k = a->dim[DIM_K];
    if (a->dim[DIM_S] != n) {
        PyErr_Format(kernel_error, "kernel buffer mass: %zd x %zd, expected a square matrix", n, a->dim[DIM_S]);
        return -1;
    }
    const Buffer *b = a->buffer;
    void *const *o = a->data + 9;
    *r = (RowJob){n, k, n + 2 * k, &b[0].view, &b[1].view, &b[2].view, &b[3].view, &b[4].view, &b[5].view,
                  &b[6].view, &b[7].view, a->number[8], o[0], o[1], o[2], o[3], o[4], o[5], o[6]};
    return 0;
}

/* The dynamics rows [M, -J_N^T, -J_T^T] and every contact's rows of the job. */
static void fill_rows(const RowJob *r) {
    Py_ssize_t n = r->n, k = r->k, nx = r->nx;
    for (Py_ssize_t i = 0; i < n; i++) {
        for (Py_ssize_t c = 0; c < n; c++) {
            r->dynamics[i * nx + c] = at2(r->mass, i, c);
        }
        for (Py_ssize_t j = 0; j < k; j++) {
            r->dynamics[i * nx + n + j] = -at2(r->jn, j, i);
            r->dynamics[i * nx + n + k + j] = -at2(r->jt, j, i);
        }
    }
    memset(r->eq, 0, (size_t)(k * ROW_LETTERS * EQUALITY_ROWS * nx) * sizeof(double));
    memset(r->eq_rhs, 0, (size_t)(k * ROW_LETTERS * EQUALITY_ROWS) * sizeof(double));
    memset(r->ineq, 0, (size_t)(k * ROW_LETTERS * INEQUALITY_ROWS * nx) * sizeof(double));
    memset(r->ineq_rhs, 0, (size_t)(k * ROW_LETTERS * INEQUALITY_ROWS) * sizeof(double));
    memset(r->valid, 0, (size_t)(k * ROW_LETTERS * INEQUALITY_ROWS));
    memset(r->motion, 0, (size_t)(k * ROW_LETTERS * INEQUALITY_ROWS));
    for (Py_ssize_t i = 0; i < k; i++) {
        contact_rows_of(r, i);
    }
}

static PyObject *contact_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    RowJob r;
    PyObject *result = NULL;
    if (parse(&rows_signature, args, nargs, &a) == 0 && row_job(&a, &r) == 0) {
        fill_rows(&r);
        result = Py_NewRef(Py_None);
    }
    release_args(&a);
    return result;
}

/* The motion LP's rows of a mode (frcontrol.engine.domain_rows, then motion_margin's rows): with
 * H = [G X_u, G X_w; C, 0] and h = [g - G x_0; d], out = [H, t] where t is each moving row's norm
 * ||H_i|| (0 elsewhere) and h_out = h. motion (one flag per row of G) marks the motion rows; the
 * input limits' rows C u <= d never are. A row is constant when its norm is at most
 * zero_row_tolerance * max(1, the largest norm); a motion row is moving unless constant. Returns -1
 * when a constant motion row has h_i < -domain_tolerance (the set is empty), else
 * 1 (a constant motion row has h_i <= domain_tolerance) + 2 (some row is moving). */
static const Arg margin_table[] = {
    {"G", 'd', 2, {DIM_ROWS, DIM_NX}, 0}, {"X_u", 'd', 2, {DIM_NX, DIM_M}, 0}, {"X_w", 'd', 2, {DIM_NX, DIM_P}, 0},
    {"x_0", 'd', 1, {DIM_NX}, 0}, {"g", 'd', 1, {DIM_ROWS}, 0}, {"C", 'd', 2, {DIM_COUNT, DIM_M}, 0},
    {"d", 'd', 1, {DIM_COUNT}, 0}, {"motion", '?', 1, {DIM_ROWS}, 0}, {"out", 'd', 2, {DIM_T, DIM_S}, WRITE},
    {"h_out", 'd', 1, {DIM_T}, WRITE}, {"zero_row_tolerance", 'f', 0, {0}, 0},
    {"domain_tolerance", 'f', 0, {0}, 0}};
static void derive_margin(Py_ssize_t *dim) { /* out: (r + rows of C, m + p + 1) */
    derive_dim(dim, DIM_T, dim[DIM_ROWS] >= 0 && dim[DIM_COUNT] >= 0, dim[DIM_ROWS] + dim[DIM_COUNT]);
    derive_dim(dim, DIM_S, dim[DIM_M] >= 0 && dim[DIM_P] >= 0, dim[DIM_M] + dim[DIM_P] + 1);
}
static const Signature margin_signature = {"margin_rows", 12, margin_table, derive_margin};

typedef struct {
    Py_ssize_t r, nx, m, p;
    const double *G, *X_u, *X_w, *x_0, *g, *C, *d;
} MarginJob;

/* Row i of [H, .] into row (its first m + p entries) and h_i into h; returns the row's norm. */
static double margin_row(const MarginJob *job, Py_ssize_t i, double *row, double *h) {
    Py_ssize_t m = job->m, p = job->p, nx = job->nx, d = m + p;
    if (i < job->r) {
        const double *Gi = job->G + i * nx;
        double v = job->g[i];
        memset(row, 0, (size_t)d * sizeof(double));
        for (Py_ssize_t k = 0; k < nx; k++) {
            double a = Gi[k];
            if (a == 0.0) {
                continue;
            }
            for (Py_ssize_t j = 0; j < m; j++) {
                row[j] += a * job->X_u[k * m + j];
            }
            for (Py_ssize_t j = 0; j < p; j++) {
                row[m + j] += a * job->X_w[k * p + j];
            }
            v -= a * job->x_0[k];
        }
        *h = v;
    } else {
        memcpy(row, job->C + (i - job->r) * m, (size_t)m * sizeof(double));
        memset(row + m, 0, (size_t)p * sizeof(double));
        *h = job->d[i - job->r];
    }
    double sum = 0.0;
    for (Py_ssize_t j = 0; j < d; j++) {
        sum += row[j] * row[j];
    }
    return sqrt(sum);
}

/* The flags of margin_rows (or -1) from the rows' norms, each moving row's norm written into its t. */
static long margin_flags(const double *norms, Py_ssize_t rows, Py_ssize_t r, const unsigned char *motion,
                         double floor, double domain_tolerance, double *out, Py_ssize_t width, const double *h) {
    long flags = 0;
    for (Py_ssize_t i = 0; i < rows; i++) {
        int constant = norms[i] <= floor, moves = i < r && motion[i];
        out[i * width + width - 1] = moves && !constant ? norms[i] : 0.0;
        if (moves && constant) {
            if (h[i] < -domain_tolerance) {
                return -1;
            }
            if (h[i] <= domain_tolerance) {
                flags |= 1;
            }
        } else if (moves) {
            flags |= 2;
        }
    }
    return flags;
}

static PyObject *margin_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    double *norms = NULL;
    if (parse(&margin_signature, args, nargs, &a)) {
        goto done;
    }
    MarginJob job = {a.dim[DIM_ROWS], a.dim[DIM_NX], a.dim[DIM_M], a.dim[DIM_P], a.data[0], a.data[1],
                     a.data[2], a.data[3], a.data[4], a.data[5], a.data[6]};
    Py_ssize_t rows = a.dim[DIM_T], width = a.dim[DIM_S];
    double *out = a.data[8], *h = a.data[9], largest = 0.0;
    norms = PyMem_Malloc((size_t)(rows + 1) * sizeof(double));
    if (norms == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t i = 0; i < rows; i++) {
        norms[i] = margin_row(&job, i, out + i * width, &h[i]);
        largest = norms[i] > largest ? norms[i] : largest;
    }
    double floor = a.number[10] * (largest > 1.0 ? largest : 1.0);
    result = PyLong_FromLong(margin_flags(norms, rows, job.r, a.data[7], floor, a.number[11], out, width, h));
done:
    PyMem_Free(norms);
    release_args(&a);
    return result;
}

/* ------------------------------------------------------------------------------------------------
 * margin_lp: the motion LP without equalities (frcontrol.engine._margin_lp), solved in the kernel.
 * Maximise t over x = (z, t), the rows A x <= h (R rows, n = d + 1 columns, t's last) and
 * 0 <= t <= cap. Each row is divided by its norm; a constant row (norm at most zero_row_tolerance
 * times max(1, the largest norm), as margin_rows) is left out when h_i >= -residual, and makes the
 * LP undecided otherwise. Solved through the dual, min h'y + cap y_c s.t. A'y + (y_c - y_0) e_t = e_t
 * and y, y_c, y_0 >= 0, by a dense primal simplex: Dantzig's rule, Bland's for good once more than n
 * pivots in a row were degenerate (no cycling), at most SIMPLEX_PIVOTS_PER_COLUMN pivots per
 * column. It starts from the basis {artificial e_j (j < n - 1), y_c}: feasible at once (y_c = 1);
 * the artificials are held at 0 (a pivot on any usable entry of an artificial's row takes it out,
 * and an artificial never enters). A reduced cost above -optimality counts as optimal. At the
 * optimum x is the basis' multipliers (minus the artificials' reduced costs), so every row holds
 * to `optimality` (its reduced cost is its slack); an unbounded dual is a Farkas ray.
 *
 * An answer is given only when checked, every test on the unit rows:
 *   ABOVE: x violates no row (nor 0 <= t <= cap) by more than `residual`, every row (constant ones
 *          too, unscaled) by more than residual (1 + |h_i|), and t > domain_tolerance band;
 *   BELOW: the same x (the set is not empty), and a dual y >= 0 whose residual is at most
 *          `residual` and whose bound h'y + cap y_c < domain_tolerance / band (weak duality: no
 *          point z has a larger t than that bound plus residual |z|_1);
 *   EMPTY: a ray y >= 0 whose residual is at most `residual` sum(y) and whose h'y + cap y_c is below
 *          -empty sum(y): every z violates some unit row by about `empty` or more (less residual |z|).
 * Anything else (a margin within the band, a failed check, the pivot limit, a NaN) is UNDECIDED:
 * the caller solves the LP by the door (DAQP). Returns the code; x (n) holds the point of ABOVE
 * and BELOW. */
enum { LP_UNDECIDED = 0, LP_ABOVE = 1, LP_BELOW = 2, LP_EMPTY = 3 };
#define SIMPLEX_PIVOTS_PER_COLUMN 20 /* the pivot limit: this many per column of the dual's tableau */

static const Arg margin_lp_table[] = {
    {"rows", 'd', 2, {DIM_T, DIM_S}, 0}, {"h", 'd', 1, {DIM_T}, 0}, {"x", 'd', 1, {DIM_S}, WRITE},
    {"cap", 'f', 0, {0}, 0}, {"domain_tolerance", 'f', 0, {0}, 0}, {"band", 'f', 0, {0}, 0},
    {"residual", 'f', 0, {0}, 0}, {"empty", 'f', 0, {0}, 0}, {"pivot", 'f', 0, {0}, 0},
    {"optimality", 'f', 0, {0}, 0}, {"zero_row_tolerance", 'f', 0, {0}, 0}};
static const Signature margin_lp_signature = {"margin_lp", 11, margin_lp_table, NULL};

typedef struct {
    double cap, domain, band, residual, empty, pivot, optimality, zero_row;
} LPTolerances;

typedef struct {
    Py_ssize_t n, rows, cols; /* the tableau: n rows; cols = rows + 2 + n (rows' y, y_c, y_0, artificials) */
    double *T, *b, *rc, *cost; /* T (n, cols), b (n), the reduced costs and costs (cols) */
    double *unit, *h_unit;     /* the kept rows divided by their norms (rows, n), and their h */
    double *y;                 /* a dual point or ray over the real columns (rows + 2) */
    Py_ssize_t *basis;         /* per tableau row, its basic column */
    Py_ssize_t capacity_rows;  /* R: the rows h_unit has room for (the tableau follows it) */
    const LPTolerances *tol;
} Simplex;

static int is_artificial(const Simplex *s, Py_ssize_t column) {
    return column >= s->rows + 2;
}

static void simplex_pivot(Simplex *s, Py_ssize_t r, Py_ssize_t e) {
    Py_ssize_t n = s->n, cols = s->cols;
    double *row = s->T + r * cols, inv = 1.0 / row[e];
    for (Py_ssize_t j = 0; j < cols; j++) {
        row[j] *= inv;
    }
    row[e] = 1.0;
    s->b[r] *= inv;
    for (Py_ssize_t k = 0; k < n; k++) {
        double f = s->T[k * cols + e];
        if (k == r || f == 0.0) {
            continue;
        }
        double *other = s->T + k * cols;
        for (Py_ssize_t j = 0; j < cols; j++) {
            other[j] -= f * row[j];
        }
        other[e] = 0.0;
        s->b[k] -= f * s->b[r];
    }
    double f = s->rc[e];
    for (Py_ssize_t j = 0; j < cols; j++) {
        s->rc[j] -= f * row[j];
    }
    s->rc[e] = 0.0;
    s->basis[r] = e;
    for (Py_ssize_t k = 0; k < n; k++) { /* the artificials stay at 0, the others nonnegative */
        if (s->b[k] < 0.0 || is_artificial(s, s->basis[k])) {
            s->b[k] = 0.0;
        }
    }
}

/* The leaving row for entering column e, or -1 (the dual is unbounded along e). An artificial's
 * row with a usable entry leaves first (its largest entry); else the least ratio b_k / a_k over
 * usable positive entries, ties to the largest entry (Bland: to the smallest basic column). */
static Py_ssize_t simplex_ratio(const Simplex *s, Py_ssize_t e, int bland) {
    Py_ssize_t best = -1, cols = s->cols;
    double best_ratio = HUGE_VAL, best_entry = 0.0, pivot = s->tol->pivot;
    for (Py_ssize_t k = 0; k < s->n; k++) { /* an artificial's row first */
        double a = s->T[k * cols + e];
        if (is_artificial(s, s->basis[k]) && fabs(a) > pivot && fabs(a) > best_entry) {
            best = k, best_entry = fabs(a);
        }
    }
    if (best >= 0) {
        return best;
    }
    best_entry = 0.0;
    for (Py_ssize_t k = 0; k < s->n; k++) {
        double a = s->T[k * cols + e];
        if (is_artificial(s, s->basis[k]) || a <= pivot) {
            continue;
        }
        double ratio = s->b[k] / a;
        int better = ratio < best_ratio;
        if (!better && ratio == best_ratio) {
            better = bland ? s->basis[k] < s->basis[best] : a > best_entry;
        }
        if (better) {
            best = k, best_ratio = ratio, best_entry = a;
        }
    }
    return best;
}

/* The entering column (a real one with a reduced cost below -optimality), or -1: optimal. */
static Py_ssize_t simplex_entering(const Simplex *s, int bland) {
    Py_ssize_t best = -1;
    double most = -s->tol->optimality;
    for (Py_ssize_t j = 0; j < s->rows + 2; j++) {
        if (s->rc[j] < most) {
            best = j, most = s->rc[j];
            if (bland) {
                break;
            }
        }
    }
    return best;
}

/* Column j of the dual's constraint matrix (a unit row's transpose, e_t or -e_t), entry k. */
static double dual_entry(const Simplex *s, Py_ssize_t j, Py_ssize_t k) {
    if (j < s->rows) {
        return s->unit[j * s->n + k];
    }
    return k != s->n - 1 ? 0.0 : j == s->rows ? 1.0 : -1.0;
}

/* max_k |sum_j y_j column_j[k] - target e_t[k]| over the real columns, and y's cost h'y + cap y_c. */
static double dual_residual(const Simplex *s, double target, double *cost) {
    double worst = 0.0;
    *cost = 0.0;
    for (Py_ssize_t j = 0; j < s->rows + 2; j++) {
        *cost += s->y[j] * s->cost[j];
    }
    for (Py_ssize_t k = 0; k < s->n; k++) {
        double sum = k == s->n - 1 ? -target : 0.0;
        for (Py_ssize_t j = 0; j < s->rows + 2; j++) {
            if (s->y[j] != 0.0) {
                sum += s->y[j] * dual_entry(s, j, k);
            }
        }
        worst = fabs(sum) > worst ? fabs(sum) : worst;
    }
    return worst;
}

/* EMPTY when entering column e's ray is a checked Farkas certificate, else UNDECIDED. */
static int simplex_ray(const Simplex *s, Py_ssize_t e) {
    memset(s->y, 0, (size_t)(s->rows + 2) * sizeof(double));
    s->y[e] = 1.0;
    for (Py_ssize_t k = 0; k < s->n; k++) {
        double a = -s->T[k * s->cols + e];
        if (!is_artificial(s, s->basis[k]) && a > 0.0) {
            s->y[s->basis[k]] = a;
        }
    }
    double total = 0.0, cost;
    for (Py_ssize_t j = 0; j < s->rows + 2; j++) {
        total += s->y[j];
    }
    double residual = dual_residual(s, 0.0, &cost);
    return residual <= s->tol->residual * total && cost < -s->tol->empty * total ? LP_EMPTY : LP_UNDECIDED;
}

/* ABOVE, BELOW or UNDECIDED at the simplex's optimum (x written). */
static int simplex_optimum(const Simplex *s, double *x) {
    const LPTolerances *tol = s->tol;
    Py_ssize_t n = s->n, t = n - 1;
    for (Py_ssize_t k = 0; k < n; k++) {
        x[k] = -s->rc[s->rows + 2 + k];
    }
    double violation = x[t] - tol->cap > -x[t] ? x[t] - tol->cap : -x[t];
    for (Py_ssize_t i = 0; i < s->rows; i++) {
        double sum = -s->h_unit[i];
        for (Py_ssize_t k = 0; k < n; k++) {
            sum += s->unit[i * n + k] * x[k];
        }
        violation = sum > violation ? sum : violation;
    }
    if (!(violation <= tol->residual)) {
        return LP_UNDECIDED;
    }
    if (x[t] > tol->domain * tol->band) {
        return LP_ABOVE;
    }
    memset(s->y, 0, (size_t)(s->rows + 2) * sizeof(double));
    for (Py_ssize_t k = 0; k < n; k++) {
        if (!is_artificial(s, s->basis[k])) {
            s->y[s->basis[k]] = s->b[k];
        }
    }
    double bound, residual = dual_residual(s, 1.0, &bound);
    return residual <= tol->residual && bound < tol->domain / tol->band ? LP_BELOW : LP_UNDECIDED;
}

/* The simplex on the tableau set up by simplex_start: the code, x written for ABOVE and BELOW. */
static int simplex_run(Simplex *s, double *x) {
    Py_ssize_t limit = SIMPLEX_PIVOTS_PER_COLUMN * (s->rows + 2 + s->n), degenerate = 0;
    int bland = 0;
    for (Py_ssize_t iteration = 0; iteration < limit; iteration++) {
        Py_ssize_t e = simplex_entering(s, bland);
        if (e < 0) {
            return simplex_optimum(s, x);
        }
        Py_ssize_t r = simplex_ratio(s, e, bland);
        if (r < 0) {
            return simplex_ray(s, e);
        }
        degenerate = s->b[r] == 0.0 ? degenerate + 1 : 0;
        bland = bland || degenerate > s->n;
        simplex_pivot(s, r, e);
    }
    return LP_UNDECIDED;
}

/* The unit rows of A (R, n) into s->unit and s->h_unit (their count in s->rows); 0, or UNDECIDED
 * for a NaN, an infinity or a constant row with h_i < -residual. */
static int simplex_rows(Simplex *s, const double *A, const double *h, Py_ssize_t R) {
    Py_ssize_t n = s->n, kept = 0;
    double largest = 1.0;
    for (Py_ssize_t i = 0; i < R; i++) { /* each row's norm, in h_unit for now */
        double norm = 0.0;
        for (Py_ssize_t k = 0; k < n; k++) {
            norm += A[i * n + k] * A[i * n + k];
        }
        if (!isfinite(norm) || !isfinite(h[i])) {
            return LP_UNDECIDED;
        }
        s->h_unit[i] = sqrt(norm);
        largest = s->h_unit[i] > largest ? s->h_unit[i] : largest;
    }
    double floor = s->tol->zero_row * largest;
    for (Py_ssize_t i = 0; i < R; i++) {
        double norm = s->h_unit[i];
        if (norm <= floor) { /* a constant row: it holds to round-off (checked at the end), or undecided */
            if (h[i] < -s->tol->residual) {
                return LP_UNDECIDED;
            }
            continue;
        }
        for (Py_ssize_t k = 0; k < n; k++) {
            s->unit[kept * n + k] = A[i * n + k] / norm;
        }
        s->h_unit[kept++] = h[i] / norm;
    }
    s->rows = kept;
    return 0;
}

/* The dual's tableau for the basis {artificials, y_c}: its pointers in the block after h_unit. */
static void simplex_start(Simplex *s) {
    Py_ssize_t n = s->n, kept = s->rows, cols = kept + 2 + n;
    s->cols = cols;
    s->T = s->h_unit + s->capacity_rows;
    s->b = s->T + n * cols, s->rc = s->b + n, s->cost = s->rc + cols, s->y = s->cost + cols;
    s->basis = (Py_ssize_t *)(s->y + cols);
    memset(s->T, 0, (size_t)(n * cols + n) * sizeof(double));
    for (Py_ssize_t k = 0; k < n; k++) {
        for (Py_ssize_t j = 0; j < kept; j++) {
            s->T[k * cols + j] = s->unit[j * n + k];
        }
        s->T[k * cols + kept + 2 + k] = 1.0;
        s->basis[k] = kept + 2 + k;
    }
    s->T[(n - 1) * cols + kept] = 1.0;
    s->T[(n - 1) * cols + kept + 1] = -1.0;
    s->basis[n - 1] = kept; /* y_c = 1 */
    s->b[n - 1] = 1.0;
    for (Py_ssize_t j = 0; j < cols; j++) {
        s->cost[j] = j < kept ? s->h_unit[j] : j == kept ? s->tol->cap : 0.0;
        s->rc[j] = s->cost[j] - s->tol->cap * s->T[(n - 1) * cols + j];
    }
}

/* The code after the checks of every row of A, unscaled (constant rows too): within residual (1 + |h_i|). */
static int simplex_unscaled(int code, const double *A, const double *h, const double *x, Py_ssize_t R,
                            Py_ssize_t n, double residual) {
    for (Py_ssize_t i = 0; i < R && (code == LP_ABOVE || code == LP_BELOW); i++) {
        double sum = -h[i];
        for (Py_ssize_t k = 0; k < n; k++) {
            sum += A[i * n + k] * x[k];
        }
        code = sum <= residual * (1.0 + fabs(h[i])) ? code : LP_UNDECIDED;
    }
    return code;
}

static PyObject *margin_lp(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    double *memory = NULL;
    if (parse(&margin_lp_signature, args, nargs, &a)) {
        goto done;
    }
    Py_ssize_t R = a.dim[DIM_T], n = a.dim[DIM_S], cols = R + 2 + n;
    LPTolerances tol = {a.number[3], a.number[4], a.number[5], a.number[6], a.number[7], a.number[8],
                        a.number[9], a.number[10]};
    if (n < 1) {
        PyErr_Format(kernel_error, "margin_lp: kernel buffer rows has no column for t");
        goto done;
    }
    if (!isfinite(tol.cap) || tol.cap <= 0.0 || !(tol.band >= 1.0)) {
        PyErr_Format(kernel_error, "margin_lp: cap must be positive and finite and band at least 1, got %g and %g",
                     tol.cap, tol.band);
        goto done;
    }
    /* unit (R n), h_unit (R), T (n cols), b (n), rc, cost and y (cols each), basis (n) */
    memory = PyMem_Malloc((size_t)(R * n + R + n * cols + n + 3 * cols + n) * sizeof(double));
    if (memory == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Simplex s = {.n = n, .unit = memory, .h_unit = memory + R * n, .capacity_rows = R, .tol = &tol};
    int code = simplex_rows(&s, a.data[0], a.data[1], R);
    if (code == 0) {
        simplex_start(&s);
        code = simplex_unscaled(simplex_run(&s, a.data[2]), a.data[0], a.data[1], a.data[2], R, n, tol.residual);
    }
    result = PyLong_FromLong(code);
done:
    PyMem_Free(memory);
    release_args(&a);
    return result;
}

/* frcontrol.response.certified_responses for the children of one node (they share B): per system
 * A (rows, nx), rows <= nx, the power-of-two scalings of equilibrate_stack, A_hat^T = Q R by
 * Householder reflections (Q kept as its reflections), R_1^T Y = [I, diag(r) B, diag(r) c] by forward
 * substitution, bound = ||A_hat||_F ||Y_I||_F (an upper bound of the condition number; +inf when a
 * pivot |R_jj| is at most ||A_hat||_F / limit, so no solve can certify it), and, when bound < limit,
 * X_u, x_0 = diag(s) Q_1 Y_[B c] and X_w = diag(s) Q_2. */
typedef struct {
    Py_ssize_t rows, nx, m;
    double *M, *tau, *V, *Y, *r, *s;
    double *work; /* certified_by_rows' checks: a scaled row (nx) and its products (nx + m + 1) */
} QRScratch;

/* sum_i a[i] b[i] over n entries, in four interleaved partial sums (i mod 4) added pairwise at the end:
 * independent additions, so the loop runs at the multiplier's pace rather than one addition's latency
 * per entry; as accurate as the sum in order. */
static double dot4(const double *a, const double *b, Py_ssize_t n) {
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    Py_ssize_t i = 0;
    for (; i + 4 <= n; i += 4) {
        s0 += a[i] * b[i], s1 += a[i + 1] * b[i + 1], s2 += a[i + 2] * b[i + 2], s3 += a[i + 3] * b[i + 3];
    }
    for (; i < n; i++) {
        s0 += a[i] * b[i];
    }
    return (s0 + s1) + (s2 + s3);
}

static void householder(QRScratch *w) {
    Py_ssize_t rows = w->rows, nx = w->nx;
    double *M = w->M; /* M[j * nx + i] = A_hat[j][i]: column j of S^T contiguous */
    for (Py_ssize_t j = 0; j < rows; j++) {
        double *v = M + j * nx, alpha = v[j], xnorm = dot4(v + j + 1, v + j + 1, nx - j - 1);
        double norm = sqrt(alpha * alpha + xnorm);
        if (xnorm == 0.0 || norm == 0.0) {
            w->tau[j] = 0.0; /* already triangular in this column */
            continue;
        }
        double beta = alpha > 0.0 ? -norm : norm, scale = 1.0 / (alpha - beta);
        for (Py_ssize_t i = j + 1; i < nx; i++) {
            v[i] *= scale;
        }
        w->tau[j] = (beta - alpha) / beta;
        v[j] = beta;
        for (Py_ssize_t k = j + 1; k < rows; k++) {
            double *column = M + k * nx, dot = column[j] + dot4(v + j + 1, column + j + 1, nx - j - 1);
            dot *= w->tau[j];
            column[j] -= dot;
            for (Py_ssize_t i = j + 1; i < nx; i++) { /* no sum: the compiler may vectorise it */
                column[i] -= dot * v[i];
            }
        }
    }
}

enum { APPLY_BLOCK = 64 };

/* X (nx, cols) <- Q X = H_0 ... H_{rows-1} X, the reflections applied from the last one back. Each
 * column's dot product sums over i in order, as one column at a time would; the rows are walked
 * with the columns inside (a block of them at once), so the updates run along X's rows. */
static void apply_q(const QRScratch *w, double *X, Py_ssize_t cols) {
    Py_ssize_t rows = w->rows, nx = w->nx;
    double dots[APPLY_BLOCK];
    for (Py_ssize_t j = rows - 1; j >= 0; j--) {
        double tau = w->tau[j];
        const double *v = w->M + j * nx;
        if (tau == 0.0) {
            continue;
        }
        for (Py_ssize_t k0 = 0; k0 < cols; k0 += APPLY_BLOCK) {
            Py_ssize_t width = cols - k0 < APPLY_BLOCK ? cols - k0 : APPLY_BLOCK;
            double *head = X + j * cols + k0;
            for (Py_ssize_t k = 0; k < width; k++) {
                dots[k] = head[k];
            }
            for (Py_ssize_t i = j + 1; i < nx; i++) {
                const double *x = X + i * cols + k0;
                for (Py_ssize_t k = 0; k < width; k++) {
                    dots[k] += v[i] * x[k];
                }
            }
            for (Py_ssize_t k = 0; k < width; k++) {
                dots[k] *= tau;
                head[k] -= dots[k];
            }
            for (Py_ssize_t i = j + 1; i < nx; i++) {
                double *x = X + i * cols + k0;
                for (Py_ssize_t k = 0; k < width; k++) {
                    x[k] -= dots[k] * v[i];
                }
            }
        }
    }
}

/* The power-of-two scalings r (rows) and w->s (nx) of the whole A (rows, nx), as equilibrate_stack, and
 * S^T into w->M for S the kept rows of A_hat = diag(r) A diag(s) (kept NULL: every row, w->rows of
 * them); returns ||A_hat||_F over every row. */
static double equilibrate_kept(QRScratch *w, Py_ssize_t rows, const double *A, const long long *kept, double *r) {
    Py_ssize_t q = w->rows, nx = w->nx;
    for (Py_ssize_t i = 0; i < rows; i++) {
        double top = 0.0;
        for (Py_ssize_t j = 0; j < nx; j++) {
            top = fabs(A[i * nx + j]) > top ? fabs(A[i * nx + j]) : top;
        }
        r[i] = power_of_two_scale(top);
    }
    for (Py_ssize_t j = 0; j < nx; j++) {
        double top = 0.0;
        for (Py_ssize_t i = 0; i < rows; i++) {
            double v = fabs(A[i * nx + j]) * r[i];
            top = v > top ? v : top;
        }
        w->s[j] = power_of_two_scale(top);
    }
    double size = 0.0;
    for (Py_ssize_t i = 0; i < rows; i++) {
        for (Py_ssize_t j = 0; j < nx; j++) {
            double v = A[i * nx + j] * r[i] * w->s[j];
            size += v * v;
        }
    }
    for (Py_ssize_t t = 0; t < q; t++) {
        Py_ssize_t i = kept == NULL ? t : (Py_ssize_t)kept[t];
        for (Py_ssize_t j = 0; j < nx; j++) {
            w->M[t * nx + j] = A[i * nx + j] * r[i] * w->s[j];
        }
    }
    return sqrt(size);
}

/* The factorisation of the kept rows S (w->M from equilibrate_kept): S^T = Q R, R_1^T Y = [I, (diag(r) B)_S,
 * (diag(r) c)_S], and the bound ||A_hat||_F ||Y_I||_F (+inf when a pivot |R_jj| is at most size / limit);
 * when bound < limit, w->V = Q [Y_[B c]; 0] and X_w = Q [0; I], unscaled. */
static double solve_kept(QRScratch *w, const double *B, const double *c, const long long *kept, const double *r,
                         double size, double limit, double *X_w) {
    Py_ssize_t q = w->rows, nx = w->nx, m = w->m, width = q + m + 1, p = nx - q;
    householder(w);
    for (Py_ssize_t j = 0; j < q; j++) {
        if (!(size < limit * fabs(w->M[j * nx + j]))) {
            return HUGE_VAL; /* ||R_1^-1||_F >= 1 / |R_jj|: not certified */
        }
    }
    /* R_1^T Y = [I, (diag(r) B)_S, (diag(r) c)_S] with R_1^T lower triangular: Y_I = R_1^-T is lower
     * triangular too, so row t's entries past t in Y_I stay 0 and are not touched (only their squares,
     * 0, would enter the sum) */
    double *Y = w->Y, sum = 0.0;
    for (Py_ssize_t t = 0; t < q; t++) {
        double *y = Y + t * width;
        Py_ssize_t i = kept == NULL ? t : (Py_ssize_t)kept[t];
        for (Py_ssize_t k = 0; k < width; k++) {
            y[k] = k < q ? (k == t) : k < q + m ? B[i * m + k - q] * r[i] : c[i] * r[i];
        }
        for (Py_ssize_t l = 0; l < t; l++) {
            double a = w->M[t * nx + l]; /* R[l][t] */
            const double *row = Y + l * width;
            for (Py_ssize_t k = 0; k <= l; k++) {
                y[k] -= a * row[k];
            }
            for (Py_ssize_t k = q; k < width; k++) {
                y[k] -= a * row[k];
            }
        }
        double d = w->M[t * nx + t];
        for (Py_ssize_t k = 0; k <= t; k++) {
            y[k] /= d;
        }
        for (Py_ssize_t k = q; k < width; k++) {
            y[k] /= d;
        }
        for (Py_ssize_t k = 0; k <= t; k++) {
            sum += y[k] * y[k];
        }
    }
    double bound = size * sqrt(sum);
    if (!(bound < limit)) {
        return bound;
    }
    double *V = w->V; /* Q [Y_[B c]; 0]: the minimum-norm solutions */
    for (Py_ssize_t i = 0; i < nx; i++) {
        for (Py_ssize_t k = 0; k <= m; k++) {
            V[i * (m + 1) + k] = i < q ? Y[i * width + q + k] : 0.0;
        }
    }
    apply_q(w, V, m + 1);
    memset(X_w, 0, (size_t)(nx * p) * sizeof(double)); /* Q [0; I]: the null space */
    for (Py_ssize_t k = 0; k < p; k++) {
        X_w[(q + k) * p + k] = 1.0;
    }
    apply_q(w, X_w, p);
    return bound;
}

/* X_u, x_0 = diag(s) V and X_w = diag(s) X_w: the solutions in the unscaled unknowns. */
static void unscale(const QRScratch *w, double *X_u, double *x_0, double *X_w) {
    Py_ssize_t nx = w->nx, m = w->m, p = nx - w->rows;
    for (Py_ssize_t i = 0; i < nx; i++) {
        for (Py_ssize_t k = 0; k < m; k++) {
            X_u[i * m + k] = w->V[i * (m + 1) + k] * w->s[i];
        }
        x_0[i] = w->V[i * (m + 1) + m] * w->s[i];
        for (Py_ssize_t k = 0; k < p; k++) {
            X_w[i * p + k] *= w->s[i];
        }
    }
}

/* One system of certified_children: every row kept; the response where the bound certifies it. */
static double certify_child(QRScratch *w, const double *A, const double *B, const double *c, double limit,
                            double *X_u, double *x_0, double *X_w) {
    double size = equilibrate_kept(w, w->rows, A, NULL, w->r);
    double bound = solve_kept(w, B, c, NULL, w->r, size, limit, X_w);
    if (bound < limit) {
        unscale(w, X_u, x_0, X_w);
    }
    return bound;
}

static const Arg children_table[] = {
    {"A", 'd', 3, {DIM_COUNT, DIM_ROWS, DIM_NX}, 0}, {"B", 'd', 2, {DIM_ROWS, DIM_M}, 0},
    {"c", 'd', 2, {DIM_COUNT, DIM_ROWS}, 0}, {"X_u", 'd', 3, {DIM_COUNT, DIM_NX, DIM_M}, WRITE},
    {"x_0", 'd', 2, {DIM_COUNT, DIM_NX}, WRITE}, {"X_w", 'd', 3, {DIM_COUNT, DIM_NX, DIM_P}, WRITE},
    {"bound", 'd', 1, {DIM_COUNT}, WRITE}, {"limit", 'f', 0, {0}, 0}};
static void derive_children(Py_ssize_t *dim) { /* X_w: (count, nx, nx - rows) */
    derive_dim(dim, DIM_P, dim[DIM_NX] >= 0 && dim[DIM_ROWS] >= 0 && dim[DIM_ROWS] <= dim[DIM_NX],
               dim[DIM_NX] - dim[DIM_ROWS]);
}
static const Signature children_signature = {"certified_children", 8, children_table, derive_children};

static PyObject *certified_children(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    double *memory = NULL;
    if (parse(&children_signature, args, nargs, &a)) {
        goto done;
    }
    Py_ssize_t count = a.dim[DIM_COUNT], rows = a.dim[DIM_ROWS], nx = a.dim[DIM_NX], m = a.dim[DIM_M];
    if (rows > nx || rows == 0) {
        PyErr_Format(kernel_error, "kernel buffer A: %zd rows and %zd columns, expected 0 < rows <= columns",
                     rows, nx);
        goto done;
    }
    Py_ssize_t width = rows + m + 1;
    memory = PyMem_Malloc((size_t)(nx * rows + rows + nx * (m + 1) + rows * width + rows + nx) * sizeof(double));
    if (memory == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    QRScratch w = {rows, nx, m, memory, NULL, NULL, NULL, NULL, NULL, NULL};
    w.tau = w.M + nx * rows, w.V = w.tau + rows, w.Y = w.V + nx * (m + 1), w.r = w.Y + rows * width, w.s = w.r + rows;
    const double *A = a.data[0], *B = a.data[1], *c = a.data[2];
    double *X_u = a.data[3], *x_0 = a.data[4], *X_w = a.data[5], *bound = a.data[6];
    for (Py_ssize_t i = 0; i < count; i++) {
        bound[i] = certify_child(&w, A + i * rows * nx, B, c + i * rows, a.number[7], X_u + i * nx * m,
                                 x_0 + i * nx, X_w + i * nx * (nx - rows));
    }
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(memory);
    release_args(&a);
    return result;
}

/* frcontrol.response.certified_by_rows (its NumPy twin is by_rows_factors): per system A
 * (rows, nx) and its kept rows (q <= nx of them), the power-of-two scalings r, s of the whole A (as
 * equilibrate_stack), S^T = Q R for S the kept rows of A_hat = diag(r) A diag(s) (Householder
 * reflections), R_1^T Y = [I, (diag(r) B)_S, (diag(r) c)_S] by forward substitution, the
 * minimum-norm solutions V = Q [Y_[B c]; 0] and the null space Q_2 = Q [0; I]. info (7 per system):
 * the bound ||A_hat||_F ||Y_I||_F, dropped = ||A_hat Q_2||_F, the residuals
 * ||diag(r) B - A_hat V_B||_F and ||diag(r) c - A_hat V_c||, ||A_hat||_F,
 * max(1, max |diag(r) B|, max |diag(r) c|) and ||[diag(r) B, diag(r) c]||_F. A pivot |R_jj| at most ||A_hat||_F / limit makes the
 * bound +inf; a bound at or above limit leaves the others (but ||A_hat||_F) NaN and the responses
 * unwritten. The certificate's decision is the caller's. The factorisation is certified_children's
 * (equilibrate_kept, solve_kept, unscale), with the kept rows for every row. */
enum { BY_ROWS_INFO = 7 };

/* info[1..3] of one system: ||A_hat Q_2||_F and the residuals of V on every row; info[5] the scale and
 * info[6] ||[diag(r) B, diag(r) c]||_F. Per row, its products with the p columns of X_w and the m + 1 of
 * V are summed together (over j in order: each product's sum is the one a column at a time gives). */
static void by_rows_checks(const QRScratch *w, Py_ssize_t rows, const double *A, const double *B, const double *c,
                           const double *r, const double *X_w, double *info) {
    Py_ssize_t nx = w->nx, m = w->m, p = nx - w->rows;
    double dropped = 0.0, res_B = 0.0, res_c = 0.0, scale = 1.0, right2 = 0.0;
    double *row = w->work, *sums = w->work + nx; /* sums: p for X_w, then m + 1 for V */
    for (Py_ssize_t i = 0; i < rows; i++) {
        const double *a = A + i * nx;
        for (Py_ssize_t j = 0; j < nx; j++) {
            row[j] = a[j] * r[i] * w->s[j];
        }
        memset(sums, 0, (size_t)(p + m + 1) * sizeof(double));
        for (Py_ssize_t j = 0; j < nx; j++) {
            const double *x = X_w + j * p, *v = w->V + j * (m + 1);
            for (Py_ssize_t k = 0; k < p; k++) {
                sums[k] += row[j] * x[k];
            }
            for (Py_ssize_t k = 0; k <= m; k++) {
                sums[p + k] += row[j] * v[k];
            }
        }
        for (Py_ssize_t k = 0; k < p; k++) {
            dropped += sums[k] * sums[k];
        }
        for (Py_ssize_t k = 0; k <= m; k++) {
            double right = k < m ? B[i * m + k] * r[i] : c[i] * r[i];
            scale = fabs(right) > scale ? fabs(right) : scale;
            right2 += right * right;
            double d = right - sums[p + k];
            if (k < m) {
                res_B += d * d;
            } else {
                res_c += d * d;
            }
        }
    }
    info[1] = sqrt(dropped), info[2] = sqrt(res_B), info[3] = sqrt(res_c), info[5] = scale, info[6] = sqrt(right2);
}

static void by_rows_system(QRScratch *w, Py_ssize_t rows, const double *A, const double *B, const double *c,
                           const long long *kept, double limit, double *r, double *X_u, double *x_0, double *X_w,
                           double *info) {
    double size = equilibrate_kept(w, rows, A, kept, r);
    info[0] = solve_kept(w, B, c, kept, r, size, limit, X_w);
    info[1] = info[2] = info[3] = info[5] = info[6] = NAN, info[4] = size;
    if (info[0] < limit) {
        by_rows_checks(w, rows, A, B, c, r, X_w, info);
        unscale(w, X_u, x_0, X_w);
    }
}

static const Arg by_rows_table[] = {
    {"A", 'd', 3, {DIM_COUNT, DIM_ROWS, DIM_NX}, 0}, {"B", 'd', 2, {DIM_ROWS, DIM_M}, 0},
    {"c", 'd', 2, {DIM_COUNT, DIM_ROWS}, 0}, {"kept", 'q', 2, {DIM_COUNT, DIM_S}, 0},
    {"X_u", 'd', 3, {DIM_COUNT, DIM_NX, DIM_M}, WRITE}, {"x_0", 'd', 2, {DIM_COUNT, DIM_NX}, WRITE},
    {"X_w", 'd', 3, {DIM_COUNT, DIM_NX, DIM_P}, WRITE}, {"info", 'd', 2, {DIM_COUNT, FIX(BY_ROWS_INFO)}, WRITE},
    {"limit", 'f', 0, {0}, 0}};
static void derive_by_rows(Py_ssize_t *dim) { /* X_w: (count, nx, nx - q) */
    derive_dim(dim, DIM_P, dim[DIM_NX] >= 0 && dim[DIM_S] >= 0 && dim[DIM_S] <= dim[DIM_NX],
               dim[DIM_NX] - dim[DIM_S]);
}
static const Signature by_rows_signature = {"certified_by_rows", 9, by_rows_table, derive_by_rows};

static PyObject *certified_by_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    double *memory = NULL;
    if (parse(&by_rows_signature, args, nargs, &a)) {
        goto done;
    }
    Py_ssize_t count = a.dim[DIM_COUNT], rows = a.dim[DIM_ROWS], nx = a.dim[DIM_NX], m = a.dim[DIM_M];
    Py_ssize_t q = a.dim[DIM_S];
    if (q > nx || q == 0) {
        PyErr_Format(kernel_error, "kernel buffer kept: %zd rows kept of %zd columns, expected 0 < kept <= columns",
                     q, nx);
        goto done;
    }
    const long long *kept = a.data[3];
    for (Py_ssize_t t = 0; t < count * q; t++) {
        if (kept[t] < 0 || kept[t] >= rows) {
            PyErr_Format(kernel_error, "kernel buffer kept: row %lld of a system of %zd rows", kept[t], rows);
            goto done;
        }
    }
    Py_ssize_t width = q + m + 1;
    memory = PyMem_Malloc((size_t)(nx * q + q + nx * (m + 1) + q * width + rows + nx + 2 * nx + m + 1) *
                          sizeof(double));
    if (memory == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    QRScratch w = {q, nx, m, memory, NULL, NULL, NULL, NULL, NULL, NULL};
    w.tau = w.M + nx * q, w.V = w.tau + q, w.Y = w.V + nx * (m + 1), w.r = w.Y + q * width, w.s = w.r + rows;
    w.work = w.s + nx;
    const double *A = a.data[0], *B = a.data[1], *c = a.data[2];
    double *X_u = a.data[4], *x_0 = a.data[5], *X_w = a.data[6], *info = a.data[7];
    for (Py_ssize_t i = 0; i < count; i++) {
        by_rows_system(&w, rows, A + i * rows * nx, B, c + i * rows, kept + i * q, a.number[8], w.r,
                       X_u + i * nx * m, x_0 + i * nx, X_w + i * nx * (nx - q), info + i * BY_ROWS_INFO);
    }
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(memory);
    release_args(&a);
    return result;
}

/* ------------------------------------------------------------------ queries on an analysis */
/* frcontrol.query.QueryTable.decide and evaluate (the NumPy twins), point by point and mode by mode.
 *
 * Locating: per point u and mode i, the slacks h_r = (h_0[i,r] - H_u[i,r,:] . u) / norms[i,r] of the
 * mode's first rows[i] rows; a mode without ambiguity variables (p[i] = 0) holds the point when
 * every motion row has h > tol and every other h >= -tol; with one (p[i] = 1), interval_rows over
 * its rows (a = H_w1[i]) decides it and gives w; with more, its consistency rows (from
 * inequality_rows[i] on) must have h >= -tol, and the LP decides in Python (QUERY_NEEDS_PYTHON).
 *
 * Evaluating: mode i at u with ambiguity values w: x = X_u u + X_w w + x_0 and y = K [x; u; 1], whose
 * first 2k entries are the contact accelerations, the next nx the equation residuals (their largest
 * magnitude is the residual), the rest the inequality slacks G x - g (their largest, at least 0, is
 * the violation). */
enum { QUERY_OUTSIDE = 0, QUERY_INSIDE = 1, QUERY_NEEDS_PYTHON = 2 };

typedef struct {
    Py_ssize_t modes, width, m, nx, pmax, krows, acc;
    const double *H_u, *h_0, *norms, *H_w1, *X_u, *X_w, *x_0, *K;
    const unsigned char *motion;
    const long long *p, *rows, *ineq;
    double dt, zrt, cap;
} QueryTable;

static signed char locate_mode(const QueryTable *t, Py_ssize_t i, const double *u, double *h, double *centre) {
    Py_ssize_t count = (Py_ssize_t)t->rows[i], at = i * t->width, m = t->m;
    for (Py_ssize_t r = 0; r < count; r++) {
        const double *row = t->H_u + (at + r) * m;
        double v = 0.0;
        for (Py_ssize_t c = 0; c < m; c++) {
            v += row[c] * u[c];
        }
        h[r] = (t->h_0[at + r] - v) / t->norms[at + r];
    }
    *centre = 0.0;
    if (t->p[i] == 1) {
        return interval_rows(count, t->H_w1 + at, h, t->motion + at, t->dt, t->zrt, t->cap, centre) ? QUERY_INSIDE
                                                                                                  : QUERY_OUTSIDE;
    }
    for (Py_ssize_t r = t->p[i] == 0 ? 0 : (Py_ssize_t)t->ineq[i]; r < count; r++) {
        if (t->motion[at + r] ? !(h[r] > t->dt) : h[r] < -t->dt) {
            return QUERY_OUTSIDE;
        }
    }
    return t->p[i] > 1 ? QUERY_NEEDS_PYTHON : QUERY_INSIDE;
}

static void evaluate_mode(const QueryTable *t, Py_ssize_t i, const double *u, const double *w, double *x,
                          double *acc, double *residual, double *violation, double *z) {
    Py_ssize_t nx = t->nx, m = t->m, pmax = t->pmax, cols = nx + m + 1;
    for (Py_ssize_t r = 0; r < nx; r++) {
        const double *xu = t->X_u + (i * nx + r) * m, *xw = t->X_w + (i * nx + r) * pmax;
        double v = 0.0, vw = 0.0;
        for (Py_ssize_t c = 0; c < m; c++) {
            v += xu[c] * u[c];
        }
        for (Py_ssize_t c = 0; c < pmax; c++) {
            vw += xw[c] * w[c];
        }
        x[r] = v + vw + t->x_0[i * nx + r];
        z[r] = x[r];
    }
    for (Py_ssize_t c = 0; c < m; c++) {
        z[nx + c] = u[c];
    }
    z[nx + m] = 1.0;
    double res = 0.0, worst = 0.0;
    for (Py_ssize_t r = 0; r < t->krows; r++) {
        const double *row = t->K + (i * t->krows + r) * cols;
        double v = 0.0;
        for (Py_ssize_t c = 0; c < cols; c++) {
            v += row[c] * z[c];
        }
        if (r < t->acc) {
            acc[r] = v;
        } else if (r < t->acc + nx) {
            res = fabs(v) > res ? fabs(v) : res;
        } else {
            worst = v > worst ? v : worst;
        }
    }
    *residual = res;
    *violation = worst;
}

/* The table's 12 buffers and 3 tolerances, the first arguments of the three query functions. */
#define QUERY_ARGS 15
#define QUERY_TABLE                                                                                           \
    {"H_u", 'd', 3, {DIM_COUNT, DIM_ROWS, DIM_M}, 0}, {"h_0", 'd', 2, {DIM_COUNT, DIM_ROWS}, 0},              \
    {"norms", 'd', 2, {DIM_COUNT, DIM_ROWS}, 0}, {"motion", '?', 2, {DIM_COUNT, DIM_ROWS}, 0},                \
    {"H_w1", 'd', 2, {DIM_COUNT, DIM_ROWS}, 0}, {"p", 'q', 1, {DIM_COUNT}, 0}, {"rows", 'q', 1, {DIM_COUNT}, 0}, \
    {"inequality_rows", 'q', 1, {DIM_COUNT}, 0}, {"X_u", 'd', 3, {DIM_COUNT, DIM_NX, DIM_M}, 0},              \
    {"X_w", 'd', 3, {DIM_COUNT, DIM_NX, DIM_P}, 0}, {"x_0", 'd', 2, {DIM_COUNT, DIM_NX}, 0},                  \
    {"K", 'd', 3, {DIM_COUNT, DIM_K, DIM_S}, 0}, {"domain_tolerance", 'f', 0, {0}, 0},                        \
    {"zero_row_tolerance", 'f', 0, {0}, 0}, {"radius_cap", 'f', 0, {0}, 0}

static void derive_query(Py_ssize_t *dim) { /* K: (modes, rows, nx + m + 1) */
    derive_dim(dim, DIM_S, dim[DIM_NX] >= 0 && dim[DIM_M] >= 0, dim[DIM_NX] + dim[DIM_M] + 1);
}

/* The query table from its parsed arguments, checked against one another; acc: 2k. */
static int query_from(const Args *a, QueryTable *t, Py_ssize_t acc) {
    t->modes = a->dim[DIM_COUNT], t->width = a->dim[DIM_ROWS], t->m = a->dim[DIM_M], t->nx = a->dim[DIM_NX];
    t->pmax = a->dim[DIM_P], t->krows = a->dim[DIM_K], t->acc = acc;
    t->H_u = a->data[0], t->h_0 = a->data[1], t->norms = a->data[2], t->motion = a->data[3];
    t->H_w1 = a->data[4], t->p = a->data[5], t->rows = a->data[6], t->ineq = a->data[7];
    t->X_u = a->data[8], t->X_w = a->data[9], t->x_0 = a->data[10], t->K = a->data[11];
    t->dt = a->number[12], t->zrt = a->number[13], t->cap = a->number[14];
    if (acc + t->nx > t->krows) {
        PyErr_Format(kernel_error, "query: K has %zd rows, fewer than %zd + %zd", t->krows, acc, t->nx);
        return -1;
    }
    for (Py_ssize_t i = 0; i < t->modes; i++) {
        if (t->rows[i] < 0 || t->rows[i] > t->width || t->ineq[i] < 0 || t->ineq[i] > t->rows[i] || t->p[i] < 0 ||
            t->p[i] > t->pmax) {
            PyErr_Format(kernel_error, "query: mode %zd has %lld rows (%lld inequalities) of %zd, p %lld", i,
                         t->rows[i], t->ineq[i], t->width, t->p[i]);
            return -1;
        }
    }
    return 0;
}

static const Arg locate_table[] = {
    QUERY_TABLE, {"U", 'd', 2, {DIM_N, DIM_M}, 0}, {"status", 'b', 2, {DIM_N, DIM_COUNT}, WRITE},
    {"w", 'd', 2, {DIM_N, DIM_COUNT}, WRITE}};
static const Signature locate_signature = {"locate_points", QUERY_ARGS + 3, locate_table, derive_query};

/* locate_points(table..., U, status, w): every point of U (N, m) against every mode. */
static PyObject *locate_points(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    double *h = NULL;
    QueryTable t;
    if (parse(&locate_signature, args, nargs, &a) || query_from(&a, &t, 0)) {
        goto done;
    }
    const double *U = a.data[QUERY_ARGS];
    signed char *status = a.data[QUERY_ARGS + 1];
    double *w = a.data[QUERY_ARGS + 2];
    h = PyMem_Malloc((size_t)(t.width + 1) * sizeof(double));
    if (h == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t j = 0; j < a.dim[DIM_N]; j++) {
        for (Py_ssize_t i = 0; i < t.modes; i++) {
            status[j * t.modes + i] = locate_mode(&t, i, U + j * t.m, h, &w[j * t.modes + i]);
        }
    }
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(h);
    release_args(&a);
    return result;
}

static const Arg evaluate_table[] = {
    QUERY_TABLE, {"U", 'd', 2, {DIM_N, DIM_M}, 0}, {"point", 'q', 1, {DIM_T}, 0}, {"index", 'q', 1, {DIM_T}, 0},
    {"w", 'd', 2, {DIM_T, DIM_P}, 0}, {"x", 'd', 2, {DIM_T, DIM_NX}, WRITE}, {"acc", 'd', 2, {DIM_T, DIM_A}, WRITE},
    {"residual", 'd', 1, {DIM_T}, WRITE}, {"violation", 'd', 1, {DIM_T}, WRITE}};
static const Signature evaluate_signature = {"evaluate_points", QUERY_ARGS + 8, evaluate_table, derive_query};

/* evaluate_points(table..., U, point, index, w, x, acc, residual, violation): per solution s, mode
 * index[s] at U[point[s]] with the ambiguity values w[s] (p_max,). */
static PyObject *evaluate_points(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    double *z = NULL;
    QueryTable t;
    if (parse(&evaluate_signature, args, nargs, &a) || query_from(&a, &t, a.dim[DIM_A])) {
        goto done;
    }
    void *const *io = a.data + QUERY_ARGS;
    const double *U = io[0], *W = io[3];
    const long long *point = io[1], *index = io[2];
    double *X = io[4], *acc = io[5], *residual = io[6], *violation = io[7];
    Py_ssize_t count = a.dim[DIM_T], points = a.dim[DIM_N];
    for (Py_ssize_t s = 0; s < count; s++) {
        if (index[s] < 0 || index[s] >= t.modes || point[s] < 0 || point[s] >= points) {
            PyErr_Format(kernel_error, "evaluate_points: solution %zd has mode %lld of %zd, point %lld of %zd", s,
                         index[s], t.modes, point[s], points);
            goto done;
        }
    }
    z = PyMem_Malloc((size_t)(t.nx + t.m + 2) * sizeof(double));
    if (z == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t s = 0; s < count; s++) {
        evaluate_mode(&t, (Py_ssize_t)index[s], U + point[s] * t.m, W + s * t.pmax, X + s * t.nx,
                      acc + s * t.acc, &residual[s], &violation[s], z);
    }
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(z);
    release_args(&a);
    return result;
}

static const Arg point_table[] = {
    QUERY_TABLE, {"u", 'd', 1, {DIM_M}, 0}, {"status", 'b', 1, {DIM_COUNT}, WRITE}, {"w", 'd', 1, {DIM_COUNT}, WRITE},
    {"x", 'd', 2, {DIM_COUNT, DIM_NX}, WRITE}, {"acc", 'd', 2, {DIM_COUNT, DIM_A}, WRITE},
    {"residual", 'd', 1, {DIM_COUNT}, WRITE}, {"violation", 'd', 1, {DIM_COUNT}, WRITE}};
static const Signature point_signature = {"query_point", QUERY_ARGS + 7, point_table, derive_query};

/* query_point(table..., u, status, w, x, acc, residual, violation): one input u (m,) against every
 * mode, each mode that holds it (QUERY_INSIDE) evaluated at its w into its row of x (modes, nx),
 * acc (modes, 2k), residual and violation (modes,). */
static PyObject *query_point(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    double *h = NULL;
    QueryTable t;
    if (parse(&point_signature, args, nargs, &a) || query_from(&a, &t, a.dim[DIM_A])) {
        goto done;
    }
    void *const *io = a.data + QUERY_ARGS;
    const double *u = io[0];
    signed char *status = io[1];
    double *w = io[2], *X = io[3], *acc = io[4], *residual = io[5], *violation = io[6];
    h = PyMem_Malloc((size_t)(t.width + t.nx + t.m + t.pmax + 2) * sizeof(double));
    if (h == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double *z = h + t.width, *wi = z + t.nx + t.m + 1;
    for (Py_ssize_t i = 0; i < t.modes; i++) {
        status[i] = locate_mode(&t, i, u, h, &w[i]);
        if (status[i] == QUERY_INSIDE) {
            for (Py_ssize_t c = 0; c < t.pmax; c++) {
                wi[c] = c == 0 ? w[i] : 0.0;
            }
            evaluate_mode(&t, i, u, wi, X + i * t.nx, acc + i * t.acc, &residual[i], &violation[i], z);
        }
    }
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(h);
    release_args(&a);
    return result;
}

/* ------------------------------------------------------------------------------------------------
 * query_plan, query_solutions: the single query on an analysis in one call (frcontrol.query's
 * query_solutions, whose NumPy twin is the reference). query_plan holds the table's buffers once, with
 * what the answer is made of (the solution type, the modes' names and ambiguous outputs, numpy.empty,
 * the input limits); query_solutions(plan, inputs) then checks the input, locates it in every mode
 * and evaluates each that holds it (locate_mode, evaluate_mode: query_point's arithmetic, to the
 * bit), and returns the list of solutions, made as the engine makes them (object.__new__ and the
 * fields in the instance's __dict__). It returns None where the general path must answer: inputs that
 * are not plain (plain_input: a vector of m numbers or a dict of them by input name; not a batch, other
 * types, an unknown name), a NaN or infinite entry, or
 * an input outside its limits (that path raises the typed error), or a mode with two or more ambiguity
 * variables whose consistency holds there (QUERY_NEEDS_PYTHON: its w is the engine's LP, in Python). */
#define PLAN_CAPSULE "frcontrol._kernel.query_plan"
#define SOLUTION_FIELDS 11
#define PLAN_ARGS (QUERY_ARGS + 11)
enum { PLAN_TYPE = QUERY_ARGS, PLAN_MODES, PLAN_OUTPUTS, PLAN_EMPTY, PLAN_NAMES, PLAN_FLOAT64, PLAN_LOWER, PLAN_UPPER,
       PLAN_SLACK, PLAN_N, PLAN_K };

static const char *solution_field_names[SOLUTION_FIELDS] = {
    "mode", "dv", "lambda_n", "lambda_t", "a_n", "a_t", "ambiguity_dim", "ambiguous_outputs", "w",
    "equality_residual", "inequality_violation"};
static PyObject *solution_fields[SOLUTION_FIELDS]; /* interned on the first plan */

typedef struct {
    Args a; /* the table's and the limits' buffers, held for the plan's life */
    QueryTable t;
    Py_ssize_t n, k;
    const double *lower, *upper;
    double slack;
    PyObject *type, *modes, *outputs, *empty, *names, *float64; /* strong references */
} QueryPlan;

/* What a plain input is checked against (plain_input): m names, numpy.float64, the limits. */
typedef struct {
    Py_ssize_t m;
    PyObject *names, *float64;
    const double *lower, *upper;
    double slack;
} InputSpec;

/* What a solution is made of (make_solution): its class, numpy.empty, n and k. */
typedef struct {
    PyObject *type, *empty;
    Py_ssize_t n, k;
} Maker;

static const Arg plan_table[PLAN_ARGS] = {
    QUERY_TABLE, {"solution_type", 'o', 0, {0}, 0}, {"modes", 'o', 0, {0}, 0}, {"outputs", 'o', 0, {0}, 0},
    {"empty", 'o', 0, {0}, 0}, {"names", 'o', 0, {0}, 0}, {"float64", 'o', 0, {0}, 0}, {"lower", 'd', 1, {DIM_M}, 0}, {"upper", 'd', 1, {DIM_M}, 0},
    {"slack", 'f', 0, {0}, 0}, {"n", 'i', 0, {0}, 0}, {"k", 'i', 0, {0}, 0}};
static const Signature plan_signature = {"query_plan", PLAN_ARGS, plan_table, derive_query};

static void free_plan(QueryPlan *plan) {
    release_args(&plan->a);
    Py_XDECREF(plan->type);
    Py_XDECREF(plan->modes);
    Py_XDECREF(plan->outputs);
    Py_XDECREF(plan->empty);
    Py_XDECREF(plan->names);
    Py_XDECREF(plan->float64);
    PyMem_Free(plan);
}

static void plan_capsule_free(PyObject *capsule) {
    free_plan(PyCapsule_GetPointer(capsule, PLAN_CAPSULE));
}

/* Whether instances of `type` have a __dict__ (PyObject_GenericSetDict sets it). */
static int instance_dict(PyTypeObject *type) {
#ifdef Py_TPFLAGS_MANAGED_DICT
    if (type->tp_flags & Py_TPFLAGS_MANAGED_DICT) {
        return 1;
    }
#endif
    return type->tp_dictoffset != 0;
}

/* The solution fields' names, interned once (make_solution sets them). */
static int intern_solution_fields(void) {
    for (int f = 0; f < SOLUTION_FIELDS; f++) {
        if (solution_fields[f] == NULL &&
            (solution_fields[f] = PyUnicode_InternFromString(solution_field_names[f])) == NULL) {
            return -1;
        }
    }
    return 0;
}

/* names: a tuple of m str (the inputs' names), else KernelError naming `function`. */
static int check_names(PyObject *names, Py_ssize_t m, const char *function) {
    if (!PyTuple_Check(names) || PyTuple_GET_SIZE(names) != m) {
        PyErr_Format(kernel_error, "%s: names must be a tuple of %zd input names", function, m);
        return -1;
    }
    for (Py_ssize_t j = 0; j < m; j++) {
        if (!PyUnicode_Check(PyTuple_GET_ITEM(names, j))) {
            PyErr_Format(kernel_error, "%s: input name %zd is not a str", function, j);
            return -1;
        }
    }
    return 0;
}

/* The plan's own checks: names and outputs one per mode, a class whose instances object.__new__ makes
 * with a __dict__, a float subclass for numpy.float64, a name per input, n + 2k = nx. */
static int check_plan(const QueryPlan *plan, PyObject *const *args) {
    const QueryTable *t = &plan->t;
    PyObject *modes = args[PLAN_MODES], *outputs = args[PLAN_OUTPUTS], *names = args[PLAN_NAMES];
    if (!PyType_Check(args[PLAN_TYPE]) || !PyTuple_Check(modes) || !PyTuple_Check(outputs) ||
        PyTuple_GET_SIZE(modes) != t->modes || PyTuple_GET_SIZE(outputs) != t->modes) {
        PyErr_Format(kernel_error, "query_plan: solution_type must be a type, modes and outputs tuples of %zd",
                     t->modes);
        return -1;
    }
    PyTypeObject *type = (PyTypeObject *)args[PLAN_TYPE];
    if (type->tp_new != PyBaseObject_Type.tp_new || !instance_dict(type)) {
        PyErr_SetString(kernel_error, "query_plan: solution_type must be a class made by object.__new__ whose "
                                      "instances have a __dict__");
        return -1;
    }
    if (!PyType_Check(args[PLAN_FLOAT64]) || !PyType_IsSubtype((PyTypeObject *)args[PLAN_FLOAT64], &PyFloat_Type)) {
        PyErr_SetString(kernel_error, "query_plan: float64 must be a subclass of float (numpy.float64)");
        return -1;
    }
    if (check_names(names, t->m, "query_plan")) {
        return -1;
    }
    if (plan->n < 0 || plan->k < 0 || plan->n + 2 * plan->k != t->nx) {
        PyErr_Format(kernel_error, "query_plan: n + 2k = %zd + 2 * %zd is not nx = %zd", plan->n, plan->k, t->nx);
        return -1;
    }
    for (Py_ssize_t i = 0; i < t->modes; i++) {
        if (!PyUnicode_Check(PyTuple_GET_ITEM(modes, i))) {
            PyErr_Format(kernel_error, "query_plan: mode %zd has no name (a str)", i);
            return -1;
        }
    }
    return 0;
}

/* query_plan(table..., solution_type, modes, outputs, empty, names, float64, lower, upper, slack, n, k)
 * -> capsule. */
static PyObject *query_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (intern_solution_fields()) {
        return NULL;
    }
    QueryPlan *plan = PyMem_Calloc(1, sizeof(QueryPlan));
    if (plan == NULL) {
        return PyErr_NoMemory();
    }
    if (parse(&plan_signature, args, nargs, &plan->a) == 0) {
        plan->n = (Py_ssize_t)plan->a.integer[PLAN_N];
        plan->k = (Py_ssize_t)plan->a.integer[PLAN_K];
        if (query_from(&plan->a, &plan->t, 2 * plan->k) == 0 && check_plan(plan, args) == 0) {
            plan->lower = plan->a.data[PLAN_LOWER], plan->upper = plan->a.data[PLAN_UPPER];
            plan->slack = plan->a.number[PLAN_SLACK];
            plan->type = Py_NewRef(args[PLAN_TYPE]);
            plan->modes = Py_NewRef(args[PLAN_MODES]);
            plan->outputs = Py_NewRef(args[PLAN_OUTPUTS]);
            plan->empty = Py_NewRef(args[PLAN_EMPTY]);
            plan->names = Py_NewRef(args[PLAN_NAMES]);
            plan->float64 = Py_NewRef(args[PLAN_FLOAT64]);
            PyObject *capsule = PyCapsule_New(plan, PLAN_CAPSULE, plan_capsule_free);
            if (capsule != NULL) {
                return capsule;
            }
        }
    }
    free_plan(plan);
    return NULL;
}

/* One number of a plain input: an int, a float or a numpy.float64, exactly those types (reading them
 * runs no Python code), as 1; else 0 (an int too large for a float too). */
static int plain_number(const InputSpec *in, PyObject *item, double *value) {
    if (PyFloat_CheckExact(item) || Py_IS_TYPE(item, (PyTypeObject *)in->float64)) {
        *value = PyFloat_AS_DOUBLE(item); /* numpy.float64 is a float: the same layout */
        return 1;
    }
    if (!PyLong_CheckExact(item)) {
        return 0;
    }
    *value = PyLong_AsDouble(item);
    if (*value == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        return 0;
    }
    return 1;
}

/* u of a dict {input name: number} (the others 0): 1, or 0 when a key is not an input's name (a str,
 * exactly) or a value not a plain number. */
static int plain_mapping(const InputSpec *in, PyObject *inputs, double *u) {
    Py_ssize_t m = in->m, at = 0;
    PyObject *key, *item;
    memset(u, 0, (size_t)m * sizeof(double));
    while (PyDict_Next(inputs, &at, &key, &item)) {
        Py_ssize_t j = 0;
        while (j < m && !(PyUnicode_CheckExact(key) && PyUnicode_Compare(key, PyTuple_GET_ITEM(in->names, j)) == 0)) {
            j++;
        }
        if (j == m || !plain_number(in, item, &u[j])) {
            return 0;
        }
    }
    return 1;
}

/* The input u (m,) of `inputs` when it is plain: a list or tuple (exactly) of m plain numbers, a 1-D
 * float64 buffer of m entries, or a dict (exactly) {input name: plain number} (the others 0); finite
 * and within the limits (to the slack). 1: read; 0: not (the general path answers). Nothing read
 * here runs Python code, so nothing can change the input while it is read. */
static int plain_input(const InputSpec *in, PyObject *inputs, double *u) {
    Py_ssize_t m = in->m;
    if (PyDict_CheckExact(inputs)) {
        if (!plain_mapping(in, inputs, u)) {
            return 0;
        }
    } else if (PyList_CheckExact(inputs) || PyTuple_CheckExact(inputs)) {
        if (PySequence_Fast_GET_SIZE(inputs) != m) {
            return 0;
        }
        for (Py_ssize_t j = 0; j < m; j++) {
            if (!plain_number(in, PySequence_Fast_GET_ITEM(inputs, j), &u[j])) {
                return 0;
            }
        }
    } else if (PyObject_CheckBuffer(inputs)) {
        Py_buffer view;
        if (PyObject_GetBuffer(inputs, &view, PyBUF_STRIDES | PyBUF_FORMAT) != 0) {
            PyErr_Clear();
            return 0;
        }
        int plain = view.ndim == 1 && view.shape != NULL && view.shape[0] == m && view.itemsize == 8 &&
                    format_is(view.format, 'd');
        Py_ssize_t step = view.strides != NULL ? view.strides[0] : view.itemsize; /* NULL: contiguous */
        for (Py_ssize_t j = 0; plain && j < m; j++) {
            u[j] = *(const double *)((const char *)view.buf + j * step);
        }
        PyBuffer_Release(&view);
        if (!plain) {
            return 0;
        }
    } else {
        return 0;
    }
    for (Py_ssize_t j = 0; j < m; j++) {
        if (!isfinite(u[j]) || u[j] < in->lower[j] - in->slack || u[j] > in->upper[j] + in->slack) {
            return 0;
        }
    }
    return 1;
}

/* A new float64 array (count,) holding values. */
static PyObject *vector_of(PyObject *empty, const double *values, Py_ssize_t count) {
    Buffer b = {0};
    double *data = NULL;
    PyObject *array = new_array(empty, count, -1, &b, &data);
    if (array != NULL && count > 0) {
        memcpy(data, values, (size_t)count * sizeof(double));
    }
    release(&b, 1);
    return array;
}

/* A solution of mode `mode` (a str) with p ambiguity variables (w: their values) moving `outputs`
 * (a str): x (nx,) = [dv, lambda_n, lambda_t], acc (2k,) = [a_n, a_t]. */
static PyObject *make_solution(const Maker *mk, PyObject *mode, PyObject *outputs, Py_ssize_t p, const double *x,
                               const double *acc, const double *w, double residual, double violation) {
    Py_ssize_t n = mk->n, k = mk->k;
    PyObject *fields = PyDict_New(), *value = NULL, *solution = NULL;
    for (int f = 0; f < SOLUTION_FIELDS && fields != NULL; f++) { /* one at a time: stop at a failure */
        switch (f) {
        case 0: value = Py_NewRef(mode); break;
        case 1: value = vector_of(mk->empty, x, n); break;
        case 2: value = vector_of(mk->empty, x + n, k); break;
        case 3: value = vector_of(mk->empty, x + n + k, k); break;
        case 4: value = vector_of(mk->empty, acc, k); break;
        case 5: value = vector_of(mk->empty, acc + k, k); break;
        case 6: value = PyLong_FromSsize_t(p); break;
        case 7: value = Py_NewRef(outputs); break;
        case 8: value = vector_of(mk->empty, w, p); break;
        case 9: value = PyFloat_FromDouble(residual); break;
        default: value = PyFloat_FromDouble(violation); break;
        }
        if (value == NULL || PyDict_SetItem(fields, solution_fields[f], value) != 0) {
            Py_CLEAR(fields);
        }
        Py_XDECREF(value);
    }
    if (fields != NULL) {
        PyObject *no_args = PyTuple_New(0);
        solution = no_args ? PyBaseObject_Type.tp_new((PyTypeObject *)mk->type, no_args, NULL) : NULL;
        Py_XDECREF(no_args);
        if (solution != NULL && PyObject_GenericSetDict(solution, fields, NULL) != 0) {
            Py_CLEAR(solution);
        }
    }
    Py_XDECREF(fields);
    return solution;
}

/* query_solutions(plan, inputs) -> [solution, ...] or None (see above). */
static PyObject *query_solutions(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 2) {
        PyErr_Format(kernel_error, "query_solutions takes 2 arguments, got %zd", nargs);
        return NULL;
    }
    QueryPlan *plan = PyCapsule_IsValid(args[0], PLAN_CAPSULE) ? PyCapsule_GetPointer(args[0], PLAN_CAPSULE) : NULL;
    if (plan == NULL) {
        PyErr_SetString(kernel_error, "query_solutions: the first argument is not a query_plan");
        return NULL;
    }
    const QueryTable *t = &plan->t;
    double *u = PyMem_Malloc((size_t)(t->m + t->width + 2 * (t->nx + t->m + 1) + t->acc + t->pmax + 1) *
                             sizeof(double));
    if (u == NULL) {
        return PyErr_NoMemory();
    }
    double *h = u + t->m, *z = h + t->width, *x = z + t->nx + t->m + 1, *acc = x + t->nx + t->m + 1;
    double *wi = acc + t->acc;
    PyObject *found = NULL;
    InputSpec in = {t->m, plan->names, plan->float64, plan->lower, plan->upper, plan->slack};
    Maker mk = {plan->type, plan->empty, plan->n, plan->k};
    if (!plain_input(&in, args[1], u)) {
        found = Py_NewRef(Py_None);
        goto done;
    }
    if ((found = PyList_New(0)) == NULL) {
        goto done;
    }
    for (Py_ssize_t i = 0; i < t->modes; i++) {
        double centre = 0.0, residual = 0.0, violation = 0.0;
        signed char status = locate_mode(t, i, u, h, &centre);
        if (status == QUERY_NEEDS_PYTHON) { /* the general path decides its w */
            Py_SETREF(found, Py_NewRef(Py_None));
            goto done;
        }
        if (status != QUERY_INSIDE) {
            continue;
        }
        for (Py_ssize_t c = 0; c < t->pmax; c++) {
            wi[c] = c == 0 ? centre : 0.0;
        }
        evaluate_mode(t, i, u, wi, x, acc, &residual, &violation, z);
        PyObject *solution = make_solution(&mk, PyTuple_GET_ITEM(plan->modes, i), PyTuple_GET_ITEM(plan->outputs, i),
                                           (Py_ssize_t)t->p[i], x, acc, &centre, residual, violation);
        if (solution == NULL || PyList_Append(found, solution) != 0) {
            Py_XDECREF(solution);
            Py_CLEAR(found);
            goto done;
        }
        Py_DECREF(solution);
    }
done:
    PyMem_Free(u);
    return found;
}

/* ------------------------------------------------------------------------------------------------
 * scratch_plan, scratch_solutions: the single query from scratch in one call (frcontrol.engine's
 * scratch_solutions; the general path of solutions_at is the reference). scratch_plan holds what does
 * not change with the state: the robot's plan and its contacts' frames, positions and lines (as
 * robot_state takes them), the drives' damping, S^T, the friction coefficients, the input limits and
 * what a solution is made of. scratch_solutions(plan, v, inputs), after Pinocchio's pass at the state
 * (computeAllTerms, in Python), does in one call what the batch path does in several: the state
 * (fill_dynamics, fill_contacts, as robot_state), each contact's letters by its velocities
 * (ContactProblem.allowed_modes), every full mode in full_modes' order, the contact rows
 * (fill_rows, as contact_rows), every mode's certificate and decision (run_modes, as certified_modes)
 * and the admissible modes' solutions, their contact accelerations J dv + drift summed in index order.
 * It returns None where the general path must answer: an input that is not plain (plain_input), a
 * contact moving into its surface or more than max_modes modes or MAX_SCRATCH_CONTACTS contacts; False
 * where a mode neither certificate takes (deficient_modes, below), which the state decides whatever
 * the input. */
#define SCRATCH_CAPSULE "frcontrol._kernel.scratch_plan"
#define SCRATCH_ARGS 34
#define MAX_SCRATCH_CONTACTS 64 /* more contacts: the general path answers (the call's arrays are fixed) */
/* the one call's deficient modes (see that section) */
#define KEPT_GUESS 1e-8 /* a row whose part outside the kept rows' span is below this of its norm is left out */
#define MAX_DEFICIENT_P 2 /* ambiguity variables the one call decides; more: the general path */
#define POLYGON_ROWS_CAP 12 /* the largest polygon_max_rows a plan may hold (the rule's arrays are fixed) */
#define POLYGON_CANDIDATES 455 /* C(POLYGON_ROWS_CAP + 3, 3): at least C(POLYGON_ROWS_CAP + 2, 3) triples of rows */
/* polygon_rule's answers: no rule (the LPs decide), no w, a w, or the engine's w one of several */
enum { POLYGON_NO_RULE = -1, POLYGON_OUTSIDE = 0, POLYGON_INSIDE = 1, POLYGON_AMBIGUOUS = 2 };
/* deficient_mode's (and deficient_modes'): the general path answers at this state, decided, the general
 * path answers at this input */
enum { DEFICIENT_STATE = 0, DEFICIENT_DECIDED = 1, DEFICIENT_INPUT = 2 };
enum { S_ROBOT, S_FRAMES, S_POSITIONS, S_LINES, S_DAMPING, S_INPUT_MAP, S_MU, S_LOWER, S_UPPER, S_TYPE, S_EMPTY,
       S_NAMES, S_FLOAT64, S_OUTPUTS, S_SLACK, S_VELOCITY, S_MARGIN, S_TOLERANCE, S_DOMAIN, S_ZERO_ROW,
       S_MAX_MODES, S_RANK, S_ROUND_OFF, S_VOID, S_EXACT, S_BALANCING, S_OUTPUT, S_CAP, S_CONSISTENCY,
       S_VERTEX, S_SINGULAR, S_POLYGON_ROWS, S_CAPPED, S_NEAR };

static const Arg scratch_table[SCRATCH_ARGS] = {
    {"robot", 'o', 0, {0}, 0}, {"frames", 'o', 0, {0}, 0}, {"positions", 'o', 0, {0}, 0},
    {"lines", 'o', 0, {0}, 0},
    {"damping", 'd', 1, {DIM_N}, OR_NONE}, {"input_map", 'd', 2, {DIM_N, DIM_M}, 0}, {"mu", 'd', 1, {DIM_K}, 0},
    {"lower", 'd', 1, {DIM_M}, 0}, {"upper", 'd', 1, {DIM_M}, 0}, {"solution_type", 'o', 0, {0}, 0},
    {"empty", 'o', 0, {0}, 0}, {"names", 'o', 0, {0}, 0}, {"float64", 'o', 0, {0}, 0}, {"outputs", 'o', 0, {0}, 0},
    {"slack", 'f', 0, {0}, 0}, {"velocity_tolerance", 'f', 0, {0}, 0}, {"margin", 'f', 0, {0}, 0},
    {"tolerance", 'f', 0, {0}, 0}, {"domain_tolerance", 'f', 0, {0}, 0}, {"zero_row_tolerance", 'f', 0, {0}, 0},
    {"max_modes", 'i', 0, {0}, 0}, {"rank_tolerance", 'f', 0, {0}, 0}, {"round_off_rank_drop", 'f', 0, {0}, 0},
    {"void_factor", 'f', 0, {0}, 0}, {"exact_factor", 'f', 0, {0}, 0}, {"balancing_friction", 'f', 0, {0}, 0},
    {"output_tolerance", 'f', 0, {0}, 0}, {"radius_cap", 'f', 0, {0}, 0},
    {"consistency_tolerance", 'f', 0, {0}, 0}, {"vertex_tolerance", 'f', 0, {0}, 0},
    {"singular_determinant", 'f', 0, {0}, 0}, {"polygon_max_rows", 'i', 0, {0}, 0},
    {"capped_fraction", 'f', 0, {0}, 0}, {"lp_near_optimal", 'f', 0, {0}, 0}};
static const Signature scratch_signature = {"scratch_plan", SCRATCH_ARGS, scratch_table, NULL};

typedef struct {
    Args a;         /* the damping's, S^T's, mu's and the limits' buffers, held for the plan's life */
    InputSpec in;
    Maker mk;
    PyObject *robot, *frames, *positions, *outputs; /* strong references (in's and mk's too) */
    double *lines;  /* (k, LINE_ENTRIES) */
    Py_ssize_t max_modes;
    Py_ssize_t polygon_rows; /* PolygonRule's most rows (at most POLYGON_ROWS_CAP) */
    int declines;   /* a number the general path refuses (not_plain_numbers): every call answers None */
} ScratchPlan;

static void free_scratch(ScratchPlan *plan) {
    release_args(&plan->a);
    Py_XDECREF(plan->robot);
    Py_XDECREF(plan->frames);
    Py_XDECREF(plan->positions);
    Py_XDECREF(plan->outputs);
    Py_XDECREF(plan->in.names);
    Py_XDECREF(plan->in.float64);
    Py_XDECREF(plan->mk.type);
    Py_XDECREF(plan->mk.empty);
    PyMem_Free(plan->lines);
    PyMem_Free(plan);
}

static void scratch_capsule_free(PyObject *capsule) {
    free_scratch(PyCapsule_GetPointer(capsule, SCRATCH_CAPSULE));
}

/* The plan of a scratch_plan capsule, or NULL (no error set). */
static ScratchPlan *scratch_plan_of(PyObject *capsule) {
    return PyCapsule_IsValid(capsule, SCRATCH_CAPSULE) ? PyCapsule_GetPointer(capsule, SCRATCH_CAPSULE) : NULL;
}

/* Whether the n values at v are all finite. */
static int all_finite(const double *v, Py_ssize_t n) {
    for (Py_ssize_t i = 0; i < n; i++) {
        if (!isfinite(v[i])) {
            return 0;
        }
    }
    return 1;
}

/* Whether the plan holds a number ContactProblem.check_numbers refuses: S^T or mu not finite, a negative
 * mu, a NaN input limit. */
static int not_plain_numbers(const Args *a) {
    Py_ssize_t n = a->dim[DIM_N], m = a->dim[DIM_M], k = a->dim[DIM_K] < 0 ? 0 : a->dim[DIM_K];
    const double *mu = a->data[S_MU], *lower = a->data[S_LOWER], *upper = a->data[S_UPPER];
    int bad = !all_finite(a->data[S_INPUT_MAP], n * m) || !all_finite(mu, k);
    for (Py_ssize_t i = 0; i < k; i++) {
        bad |= mu[i] < 0.0;
    }
    for (Py_ssize_t j = 0; j < m; j++) {
        bad |= isnan(lower[j]) || isnan(upper[j]);
    }
    return bad;
}

/* Whether `outputs` is a tuple of three str (the ambiguous outputs' names, in MOVES_* order). */
static int str_triple(PyObject *outputs) {
    if (!PyTuple_Check(outputs) || PyTuple_GET_SIZE(outputs) != 3) {
        return 0;
    }
    for (Py_ssize_t i = 0; i < 3; i++) {
        if (!PyUnicode_Check(PyTuple_GET_ITEM(outputs, i))) {
            return 0;
        }
    }
    return 1;
}

/* The plan's own checks: the frames one per mu, the lines' floats (into plan->lines), a solution class
 * made by object.__new__ with a __dict__, a float subclass, a name per input, a str of outputs. */
static int check_scratch(ScratchPlan *plan, PyObject *const *args) {
    const Args *a = &plan->a;
    Py_ssize_t k = a->dim[DIM_K] < 0 ? 0 : a->dim[DIM_K], m = a->dim[DIM_M];
    PyObject *type = args[S_TYPE], *names = args[S_NAMES], *float64 = args[S_FLOAT64];
    if (args[S_ROBOT] == Py_None) { /* a problem's plan: problem_solutions gives the state */
        if (args[S_FRAMES] != Py_None || args[S_POSITIONS] != Py_None || args[S_LINES] != Py_None) {
            PyErr_SetString(kernel_error,
                            "scratch_plan: without a robot, frames, positions and lines must be None");
            return -1;
        }
    } else {
        if (!PyTuple_Check(args[S_FRAMES]) || PyTuple_GET_SIZE(args[S_FRAMES]) != k || !PyTuple_Check(args[S_POSITIONS]) ||
            PyTuple_GET_SIZE(args[S_POSITIONS]) != k) {
            PyErr_Format(kernel_error, "scratch_plan: frames and positions must be tuples of %zd, one per mu", k);
            return -1;
        }
        StateJob lines = {.k = k};
        if (take_lines(args[S_LINES], &lines)) {
            PyMem_Free(lines.lines);
            return -1;
        }
        plan->lines = lines.lines;
    }
    if (!PyType_Check(type) || ((PyTypeObject *)type)->tp_new != PyBaseObject_Type.tp_new ||
        !instance_dict((PyTypeObject *)type) || !PyType_Check(float64) ||
        !PyType_IsSubtype((PyTypeObject *)float64, &PyFloat_Type) || !str_triple(args[S_OUTPUTS])) {
        PyErr_SetString(kernel_error, "scratch_plan: solution_type must be a class made by object.__new__ whose "
                                      "instances have a __dict__, float64 a subclass of float, outputs a tuple of "
                                      "3 str");
        return -1;
    }
    long long most = a->integer[S_POLYGON_ROWS];
    if (most < 0 || most > POLYGON_ROWS_CAP) {
        PyErr_Format(kernel_error, "scratch_plan: polygon_max_rows must be in [0, %d], got %lld", POLYGON_ROWS_CAP,
                     most);
        return -1;
    }
    return check_names(names, m, "scratch_plan");
}

/* scratch_plan(robot, frames, positions, lines, damping, input_map, mu, lower, upper, solution_type,
 * empty, names, float64, outputs, slack, velocity_tolerance, margin, tolerance, domain_tolerance,
 * zero_row_tolerance, max_modes, rank_tolerance, round_off_rank_drop, void_factor, exact_factor,
 * balancing_friction, output_tolerance, radius_cap, consistency_tolerance, vertex_tolerance,
 * singular_determinant, polygon_max_rows, capped_fraction, lp_near_optimal) -> capsule (scratch_table). */
static PyObject *scratch_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (intern_solution_fields() || intern_names()) {
        return NULL;
    }
    ScratchPlan *plan = PyMem_Calloc(1, sizeof(ScratchPlan));
    if (plan == NULL) {
        return PyErr_NoMemory();
    }
    if (parse(&scratch_signature, args, nargs, &plan->a) == 0 && check_scratch(plan, args) == 0) {
        const Args *a = &plan->a;
        plan->in = (InputSpec){a->dim[DIM_M], Py_NewRef(args[S_NAMES]), Py_NewRef(args[S_FLOAT64]),
                               a->data[S_LOWER], a->data[S_UPPER], a->number[S_SLACK]};
        plan->mk = (Maker){Py_NewRef(args[S_TYPE]), Py_NewRef(args[S_EMPTY]), a->dim[DIM_N],
                           a->dim[DIM_K] < 0 ? 0 : a->dim[DIM_K]};
        plan->robot = Py_NewRef(args[S_ROBOT]);
        plan->frames = Py_NewRef(args[S_FRAMES]);
        plan->positions = Py_NewRef(args[S_POSITIONS]);
        plan->outputs = Py_NewRef(args[S_OUTPUTS]);
        plan->max_modes = (Py_ssize_t)a->integer[S_MAX_MODES];
        plan->polygon_rows = (Py_ssize_t)a->integer[S_POLYGON_ROWS];
        plan->declines = not_plain_numbers(a);
        PyObject *capsule = PyCapsule_New(plan, SCRATCH_CAPSULE, scratch_capsule_free);
        if (capsule != NULL) {
            return capsule;
        }
    }
    free_scratch(plan);
    return NULL;
}

/* Each contact's letters by its velocities (ContactProblem.allowed_modes: S only when v_N > tol, S R
 * when v_T > tol, S L when v_T < -tol, all four else), as bit masks over S L R F; the number of full
 * modes, or -1 when a contact moves into its surface (v_N < -tol) or there are more than `most`. */
static Py_ssize_t allowed_letters(const double *vn, const double *vt, Py_ssize_t k, double tol, Py_ssize_t most,
                                  int *mask) {
    Py_ssize_t count = 1;
    for (Py_ssize_t i = 0; i < k; i++) {
        if (vn[i] < -tol) {
            return -1;
        }
        mask[i] = vn[i] > tol ? 1 : vt[i] > tol ? 1 | 4 : vt[i] < -tol ? 1 | 2 : 15;
        count *= (mask[i] == 15 ? 4 : mask[i] == 1 ? 1 : 2);
        if (count > most) {
            return -1;
        }
    }
    return count;
}

/* Every full mode's letter indices (count, k) in full_modes' order: the last contact's letter varies
 * fastest, each contact's letters in S L R F order. */
static void full_letters(const int *mask, Py_ssize_t k, Py_ssize_t count, long long *letters) {
    long long *at = letters;
    for (Py_ssize_t mode = 0; mode < count; mode++) {
        Py_ssize_t rest = mode;
        for (Py_ssize_t i = k - 1; i >= 0; i--) {
            int choices[LETTERS], c = 0;
            for (int letter = 0; letter < LETTERS; letter++) {
                if (mask[i] >> letter & 1) {
                    choices[c++] = letter;
                }
            }
            at[i] = choices[rest % c];
            rest /= c;
        }
        at += k;
    }
}

/* A float64 view (rows, cols) of data as at2 reads it (strides in bytes). */
static void raw_view(Py_buffer *view, Py_ssize_t *strides, double *data, Py_ssize_t cols) {
    memset(view, 0, sizeof(*view));
    strides[0] = cols * (Py_ssize_t)sizeof(double);
    strides[1] = (Py_ssize_t)sizeof(double);
    view->buf = data;
    view->strides = strides;
}

typedef struct {
    double *state;          /* the state's arrays (w->job's) */
    double *memory;         /* the rows' arrays, then x, residual and violation per mode */
    unsigned char *flags;   /* valid, motion, then status per mode */
    long long *letters;     /* (count, k) */
    double *work;           /* run_modes' scratch (scratch()): s and Su */
    Scratch s;
    double *Su;
    double *w;              /* per mode: its w (MAX_DEFICIENT_P entries, the first pdims[mode] read) */
    signed char *moves;     /* per mode: -1 (no ambiguity variable) or moved_by's code */
    signed char *pdims;     /* per mode: its ambiguity variables */
    StateJob job;
    Py_ssize_t count;
} ScratchWork;

static void free_work(ScratchWork *w) {
    PyMem_Free(w->state);
    PyMem_Free(w->memory);
    PyMem_Free(w->flags);
    PyMem_Free(w->letters);
    PyMem_Free(w->work);
}

/* The state's arrays in w->job (robot_state's: M, h, the points, [J_N; J_T], then gaps, v_N, v_T,
 * drift_N, drift_T), in one new block; -1 with an error set. */
static int state_block(const ScratchPlan *plan, ScratchWork *w) {
    StateJob *job = &w->job;
    Py_ssize_t n = plan->mk.n, k = plan->mk.k;
    w->state = PyMem_Calloc((size_t)(n * n + n + 2 * k + 2 * k * n + 5 * k + 1), sizeof(double));
    if (w->state == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    job->n = n, job->k = k;
    job->mass = w->state, job->bias = job->mass + n * n, job->points = job->bias + n;
    job->rows = job->points + 2 * k, job->values = job->rows + 2 * k * n;
    return 0;
}

/* The state at v (fill_dynamics, fill_contacts), into w->job's arrays; -1 with an error set. */
static int scratch_state(const ScratchPlan *plan, const Py_buffer *v, ScratchWork *w, Buffer *b) {
    StateJob *job = &w->job;
    if (plan->robot == Py_None) {
        PyErr_SetString(kernel_error, "scratch_solutions: the plan is a problem's (problem_solutions takes it)");
        return -1;
    }
    if (take_robot(plan->robot, plan->frames, plan->positions, plan->mk.n, b, job) || state_block(plan, w)) {
        return -1;
    }
    job->v = v, job->lines = plan->lines, job->damping = plan->a.data[S_DAMPING];
    fill_dynamics(job, &b[0].view, &b[1].view);
    return fill_contacts(job, plan->frames, plan->positions);
}

/* The contact rows of the state (fill_rows) into p's arrays, the modes' outputs after them; -1 with
 * an error set. */
static int scratch_rows(const ScratchPlan *plan, ScratchWork *w, Problem *p) {
    const StateJob *job = &w->job;
    Py_ssize_t n = p->n, k = p->k, nx = p->nx, count = w->count;
    Py_ssize_t pairs = k * ROW_LETTERS * EQUALITY_ROWS, cells = k * ROW_LETTERS * INEQUALITY_ROWS;
    w->memory = PyMem_Malloc((size_t)(n * nx + pairs * (nx + 1) + cells * (nx + 1) +
                                      count * (nx + 2 + MAX_DEFICIENT_P) + 1) * sizeof(double));
    w->flags = PyMem_Malloc((size_t)(2 * cells + 3 * count + 1));
    if (w->memory == NULL || w->flags == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    double *at = w->memory;
    RowJob r = {.n = n, .k = k, .nx = nx, .tolerance = plan->a.number[S_VELOCITY]};
    r.dynamics = at, at += n * nx;
    r.eq = at, at += pairs * nx;
    r.eq_rhs = at, at += pairs;
    r.ineq = at, at += cells * nx;
    r.ineq_rhs = at, at += cells;
    p->x = at, at += count * nx;
    p->residual = at, at += count;
    p->violation = at, at += count;
    w->w = at;
    r.valid = w->flags, r.motion = w->flags + cells;
    p->status = (signed char *)(w->flags + 2 * cells);
    w->moves = p->status + count;
    w->pdims = w->moves + count;
    Py_buffer views[8];
    Py_ssize_t strides[8][2];
    double *vectors[6] = {job->values + 3 * k, job->values + 4 * k, (double *)plan->a.data[S_MU],
                          job->values + k, job->values + 2 * k, NULL}; /* drift_N, drift_T, mu, v_N, v_T */
    raw_view(&views[0], strides[0], job->mass, n);
    raw_view(&views[1], strides[1], job->rows, n);
    raw_view(&views[2], strides[2], job->rows + k * n, n);
    for (int j = 0; j < 5; j++) {
        raw_view(&views[3 + j], strides[3 + j], vectors[j], 1);
    }
    r.mass = &views[0], r.jn = &views[1], r.jt = &views[2], r.dn = &views[3], r.dt = &views[4];
    r.mu = &views[5], r.vn = &views[6], r.vt = &views[7];
    fill_rows(&r);
    p->dynamics = r.dynamics, p->eq = r.eq, p->eq_rhs = r.eq_rhs, p->ineq = r.ineq, p->ineq_rhs = r.ineq_rhs;
    p->valid = r.valid, p->motion = r.motion;
    return 0;
}

/* Every full mode decided at u (run_modes) into p; -1 with an error set. */
static int scratch_modes(const ScratchPlan *plan, const double *u, const int *mask, ScratchWork *w, Problem *p) {
    const Args *a = &plan->a;
    Py_ssize_t k = plan->mk.k;
    *p = (Problem){.n = plan->mk.n, .k = k, .m = plan->in.m, .nx = plan->mk.n + 2 * k, .count = w->count};
    p->input_map = a->data[S_INPUT_MAP], p->bias = w->job.bias, p->u = u;
    p->margin = a->number[S_MARGIN], p->tolerance = a->number[S_TOLERANCE];
    p->domain_tolerance = a->number[S_DOMAIN], p->zero_row_tolerance = a->number[S_ZERO_ROW];
    w->letters = PyMem_Malloc((size_t)(w->count * k + 1) * sizeof(long long));
    if (w->letters == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    full_letters(mask, k, w->count, w->letters);
    p->letters = w->letters;
    if (scratch_rows(plan, w, p)) {
        return -1;
    }
    double *work;
    if ((w->work = scratch(p, &w->s, &w->Su, &work)) == NULL) {
        return -1;
    }
    run_modes(p, w->Su, &w->s);
    return 0;
}

/* ------------------------------------------------------------------ the one call's deficient modes
 * A mode run_modes leaves to the SVD (NOT_CERTIFIED) is certified as frcontrol.response's
 * certified_by_rows certifies one, on rows guessed here: every row of its A_hat independent of the
 * rows kept before it (independent_rows, to KEPT_GUESS; a guess, checked by the certificate). With
 * p = nx - q rows left out (p <= MAX_DEFICIENT_P ambiguity variables), the left null space L (p, nx) of
 * A_hat is found from its columns the same way (left_null) and checked: ||A_hat^T L||_F passes the
 * test the certificate puts to ||A_hat Q_2||_F, so L spans the SVD's U_2 to round-off. The right side
 * [diag(r) B, diag(r) c] is projected off L (the part in A_hat's range, which the SVD's least squares
 * solves) and certified_by_rows' checks (by_rows_ok: by_rows_certified's) run on it: the SVD would
 * find rank q outside the ill-conditioned band, its drop round-off's; X_u, x_0 are its minimum-norm
 * least-squares maps to round-off and X_w its null space in another orthonormal basis of the scaled
 * coordinates (w up to an orthogonal map: up to sign for p = 1). The consistency rows
 * E_raw = L^T diag(r) B, e_raw = -L^T diag(r) c are the SVD's up to the same kind of map, which
 * _consistent_at's rule does not see (consistent_rows). The mode is then decided as the batch path
 * decides one: sliced_rows, then one variable on its interval (interval, as rank_mode), two by
 * frcontrol.ambiguity_polygon's rule (polygon_rule). Any other mode (more variables, a certificate
 * that fails, two variables whose rule cannot be built, a sliding contact rougher than
 * balancing_friction, which rebalance_undecided may balance) leaves the answer to the general path. */

/* v minus its part in the span of the orthonormal rows basis (count, nx), twice; returns |v|^2 after. */
static double orthogonalize(const double *basis, Py_ssize_t count, Py_ssize_t nx, double *v) {
    for (int pass = 0; pass < 2; pass++) {
        for (Py_ssize_t t = 0; t < count; t++) {
            double dot = 0.0;
            for (Py_ssize_t j = 0; j < nx; j++) {
                dot += basis[t * nx + j] * v[j];
            }
            for (Py_ssize_t j = 0; j < nx; j++) {
                v[j] -= dot * basis[t * nx + j];
            }
        }
    }
    double left = 0.0;
    for (Py_ssize_t j = 0; j < nx; j++) {
        left += v[j] * v[j];
    }
    return left;
}

/* The rows of A_hat (nx, nx) independent of those before them (Gram-Schmidt, twice), into kept; their
 * count, their orthonormal basis in basis. */
static Py_ssize_t independent_rows(const double *A_hat, Py_ssize_t nx, double *basis, long long *kept) {
    Py_ssize_t q = 0;
    for (Py_ssize_t i = 0; i < nx; i++) {
        double *v = basis + q * nx, start = 0.0;
        for (Py_ssize_t j = 0; j < nx; j++) {
            v[j] = A_hat[i * nx + j];
            start += v[j] * v[j];
        }
        double left = orthogonalize(basis, q, nx, v);
        if (start > 0.0 && left > KEPT_GUESS * KEPT_GUESS * start) {
            double scale = 1.0 / sqrt(left);
            for (Py_ssize_t j = 0; j < nx; j++) {
                v[j] *= scale;
            }
            kept[q++] = i;
        }
    }
    return q;
}

/* The left null space of A_hat (nx, nx) when its columns have rank q, as independent_rows finds it
 * for its rows: A_hat's column space (basis, its first q rows), completed p = nx - q times by the unit
 * vector with the largest part outside what is found so far (1 - sum_t basis[t][j]^2, the basis being
 * orthonormal), orthogonalised; L = basis rows q..nx-1. 0, or -1 when the columns' rank is not q.
 * T (nx, nx) and cols (nx) are scratch. */
static int left_null(const double *A_hat, Py_ssize_t nx, Py_ssize_t q, double *T, double *basis, long long *cols) {
    for (Py_ssize_t i = 0; i < nx; i++) {
        for (Py_ssize_t j = 0; j < nx; j++) {
            T[j * nx + i] = A_hat[i * nx + j];
        }
    }
    if (independent_rows(T, nx, basis, cols) != q) {
        return -1;
    }
    for (Py_ssize_t found = q; found < nx; found++) {
        double *v = basis + found * nx, best = INFINITY;
        Py_ssize_t pick = 0;
        for (Py_ssize_t j = 0; j < nx; j++) {
            double inside = 0.0;
            for (Py_ssize_t t = 0; t < found; t++) {
                inside += basis[t * nx + j] * basis[t * nx + j];
            }
            if (inside < best) {
                best = inside, pick = j;
            }
        }
        memset(v, 0, (size_t)nx * sizeof(double));
        v[pick] = 1.0;
        double scale = 1.0 / sqrt(orthogonalize(basis, found, nx, v));
        for (Py_ssize_t j = 0; j < nx; j++) {
            v[j] *= scale;
        }
    }
    return 0;
}

/* frcontrol.response.by_rows_certified for one system of `rows` rows and nx unknowns (a NaN fails),
 * and, with p > 0 rows of L (p, nx), the same test of ||A_hat^T L||_F as of ||A_hat Q_2||_F. */
static int by_rows_ok(const ScratchPlan *plan, const double *info, Py_ssize_t rows, Py_ssize_t nx,
                      const double *A_hat, const double *L, Py_ssize_t p) {
    const double *number = plan->a.number;
    double small = (double)(rows < nx ? rows : nx), margin = number[S_MARGIN];
    double limit = 1.0 / (margin * number[S_TOLERANCE]);
    double rank_factor = number[S_RANK] / sqrt(small), round_off = small * number[S_ROUND_OFF];
    double residual = info[2] > info[3] ? info[2] : info[3];
    double void_bound = number[S_VOID] * info[5], exact_bound = number[S_EXACT] * info[0] * info[6];
    double left = 0.0;
    for (Py_ssize_t t = 0; t < p; t++) {
        for (Py_ssize_t j = 0; j < nx; j++) {
            double sum = 0.0;
            for (Py_ssize_t i = 0; i < rows; i++) {
                sum += A_hat[i * nx + j] * L[t * nx + i];
            }
            left += sum * sum;
        }
    }
    left = sqrt(left);
    return info[0] < limit && margin * info[1] < rank_factor * info[4] &&
           margin * info[1] <= round_off * info[4] && margin * left < rank_factor * info[4] &&
           margin * left <= round_off * info[4] && residual <= (void_bound < exact_bound ? void_bound : exact_bound);
}

/* Entry (i, j) of [diag(r) B, diag(r) c] (B (nx, m); j = m: c). */
static double scaled_right(const Scratch *s, const double *B, Py_ssize_t m, Py_ssize_t i, Py_ssize_t j) {
    return (j < m ? B[i * m + j] : s->c[i]) * s->r_scale[i];
}

/* The right side [diag(r) B, diag(r) c] off the span of L (p, nx): B' (nx, m) and c' (nx) divided by r
 * again (exact: r is powers of two), for by_rows_system; E_raw = L diag(r) B (p, m) and
 * e_raw = -L diag(r) c (p). Returns _scale_of's max(1, max |diag(r) B|, max |diag(r) c|). */
static double projected(const Scratch *s, const double *B, Py_ssize_t nx, Py_ssize_t m, const double *L,
                        Py_ssize_t p, double *Bp, double *cp, double *E, double *e) {
    double scale = 1.0;
    for (Py_ssize_t j = 0; j <= m; j++) { /* column j of [diag(r) B, diag(r) c] */
        double dots[MAX_DEFICIENT_P];
        for (Py_ssize_t t = 0; t < p; t++) {
            dots[t] = 0.0;
            for (Py_ssize_t i = 0; i < nx; i++) {
                dots[t] += L[t * nx + i] * scaled_right(s, B, m, i, j);
            }
            if (j < m) {
                E[t * m + j] = dots[t];
            } else {
                e[t] = -dots[t];
            }
        }
        for (Py_ssize_t i = 0; i < nx; i++) {
            double right = scaled_right(s, B, m, i, j), off = right;
            scale = fabs(right) > scale ? fabs(right) : scale;
            for (Py_ssize_t t = 0; t < p; t++) {
                off -= L[t * nx + i] * dots[t];
            }
            if (j < m) {
                Bp[i * m + j] = off / s->r_scale[i];
            } else {
                cp[i] = off / s->r_scale[i];
            }
        }
    }
    return scale;
}

/* _consistent_at for p <= 2 rows E u = e (E (p, m)): by E's SVD, whose right vectors and singular
 * values one-sided Jacobi rotations of its two rows give (rotated alike, e becomes Ue^T e); a
 * singular value above ct times scale is kept and its row must hold to dt, a row not kept must have
 * |e| at most ct times scale. E and e are overwritten. */
static int consistent_rows(double *E, double *e, Py_ssize_t p, Py_ssize_t m, double scale, const double *u,
                           double ct, double dt) {
    for (int sweep = 0; p == 2 && sweep < 8; sweep++) {
        double a = 0.0, b = 0.0, g = 0.0;
        for (Py_ssize_t j = 0; j < m; j++) {
            a += E[j] * E[j], b += E[m + j] * E[m + j], g += E[j] * E[m + j];
        }
        if (!(fabs(g) > DBL_EPSILON * sqrt(a * b))) {
            break;
        }
        double zeta = (b - a) / (2.0 * g);
        double t = (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
        double cs = 1.0 / sqrt(1.0 + t * t), sn = cs * t;
        for (Py_ssize_t j = 0; j <= m; j++) {
            double *x = j < m ? &E[j] : &e[0], *y = j < m ? &E[m + j] : &e[1];
            double first = *x, second = *y;
            *x = cs * first - sn * second, *y = sn * first + cs * second;
        }
    }
    for (Py_ssize_t t = 0; t < p; t++) {
        double sq = 0.0, eu = 0.0;
        for (Py_ssize_t j = 0; j < m; j++) {
            sq += E[t * m + j] * E[t * m + j], eu += E[t * m + j] * u[j];
        }
        double value = sqrt(sq), limit = ct * scale;
        if (value > limit ? !(fabs(eu - e[t]) / value <= dt) : fabs(e[t]) > limit) {
            return 0;
        }
    }
    return 1;
}

/* The three rows (a_x, a_y, c) of R meeting at a vertex v = R_T^-1 b_T (Cramer's rule): 1, or 0 when
 * |det R_T| is at most singular (they meet at no point: no candidate). */
static int vertex_of(const double (*R)[3], const double *b, const int *T, double singular, double *v) {
    const double *r0 = R[T[0]], *r1 = R[T[1]], *r2 = R[T[2]];
    double c0[3] = {r1[1] * r2[2] - r1[2] * r2[1], r1[2] * r2[0] - r1[0] * r2[2], r1[0] * r2[1] - r1[1] * r2[0]};
    double c1[3] = {r2[1] * r0[2] - r2[2] * r0[1], r2[2] * r0[0] - r2[0] * r0[2], r2[0] * r0[1] - r2[1] * r0[0]};
    double c2[3] = {r0[1] * r1[2] - r0[2] * r1[1], r0[2] * r1[0] - r0[0] * r1[2], r0[0] * r1[1] - r0[1] * r1[0]};
    double det = r0[0] * c0[0] + r0[1] * c0[1] + r0[2] * c0[2];
    if (!(fabs(det) > singular)) {
        return 0;
    }
    for (int d = 0; d < 3; d++) { /* R_T^-1 = [c0 c1 c2] / det */
        v[d] = (c0[d] * b[T[0]] + c1[d] * b[T[1]] + c2[d] * b[T[2]]) / det;
    }
    return 1;
}

/* One of PolygonRule's two LPs at its right sides b (size rows: the live rows, then s <= s_max and
 * -s <= 0): every triple's vertex, in combinations' order, and the best feasible s (-inf: none). */
static double polygon_lp(const double (*R)[3], const double *b, Py_ssize_t size, const ScratchPlan *plan,
                         double (*vertex)[3], unsigned char *feasible, Py_ssize_t *count) {
    double best = -INFINITY, vt = plan->a.number[S_VERTEX], singular = plan->a.number[S_SINGULAR];
    Py_ssize_t at = 0;
    for (int i = 0; i < size; i++) {
        for (int j = i + 1; j < size; j++) {
            for (int l = j + 1; l < size; l++, at++) {
                int T[3] = {i, j, l};
                feasible[at] = (unsigned char)vertex_of(R, b, T, singular, vertex[at]);
                for (Py_ssize_t r = 0; r < size && feasible[at]; r++) {
                    double slack = b[r] - (R[r][0] * vertex[at][0] + R[r][1] * vertex[at][1] + R[r][2] * vertex[at][2]);
                    double floor = fabs(b[r]) > 1.0 ? fabs(b[r]) : 1.0;
                    feasible[at] = slack >= -vt * floor;
                }
                if (feasible[at] && vertex[at][2] > best) {
                    best = vertex[at][2];
                }
            }
        }
    }
    *count = at;
    return best;
}

/* The live rows of a (rows, 2) (norm above zrt max(1, the largest)) as unit rows into unit, their norms
 * into norms and indices into live, their count via *count; the constant rows judged by h alone
 * (POLYGON_OUTSIDE: one fails); POLYGON_NO_RULE when the live rows do not span the plane
 * (PolygonRule.build: None). */
static int polygon_rows(const ScratchPlan *plan, const double *a, const double *h, const unsigned char *mo,
                        Py_ssize_t rows, double (*unit)[2], double *norms, Py_ssize_t *live, Py_ssize_t *count) {
    double top = 0.0, tol = plan->a.number[S_DOMAIN], cross = 0.0, all[POLYGON_ROWS_CAP];
    for (Py_ssize_t i = 0; i < rows; i++) {
        all[i] = sqrt(a[2 * i] * a[2 * i] + a[2 * i + 1] * a[2 * i + 1]);
        top = all[i] > top ? all[i] : top;
    }
    double floor = plan->a.number[S_ZERO_ROW] * (top > 1.0 ? top : 1.0);
    int ok = 1;
    *count = 0;
    for (Py_ssize_t i = 0; i < rows; i++) {
        if (!(all[i] > floor)) { /* the rule's checks: h + tol >= 0, or h - tol > 0 for a motion row */
            ok &= mo[i] ? h[i] - tol > 0.0 : !(h[i] + tol < 0.0);
            continue;
        }
        norms[*count] = all[i], live[*count] = i;
        unit[*count][0] = a[2 * i] / all[i], unit[*count][1] = a[2 * i + 1] / all[i];
        for (Py_ssize_t j = 0; j < *count; j++) {
            double d = fabs(unit[j][0] * unit[*count][1] - unit[j][1] * unit[*count][0]);
            cross = d > cross ? d : cross;
        }
        (*count)++;
    }
    if (*count < 2 || !(cross > plan->a.number[S_SINGULAR])) {
        return POLYGON_NO_RULE;
    }
    return ok ? POLYGON_INSIDE : POLYGON_OUTSIDE;
}

/* Whether a feasible vertex of an LP (vertex, feasible: candidates of them) with s at least `floor`,
 * and, with tie > 0, |w|^2 within tie of `nearest`, lies farther than VERTEX_TOLERANCE max(1, |w|) from w. */
static int other_vertex(const ScratchPlan *plan, const double (*vertex)[3], const unsigned char *feasible,
                        Py_ssize_t candidates, double floor, double nearest, double tie, const double *w) {
    double far = plan->a.number[S_VERTEX] * (sqrt(nearest) > 1.0 ? sqrt(nearest) : 1.0);
    for (Py_ssize_t t = 0; t < candidates; t++) {
        const double *v = vertex[t];
        double sq = v[0] * v[0] + v[1] * v[1];
        if (feasible[t] && v[2] >= floor && (tie <= 0.0 || fabs(sq - nearest) <= tie) &&
            (fabs(v[0] - w[0]) > far || fabs(v[1] - w[1]) > far)) {
            return 1;
        }
    }
    return 0;
}

/* The engine's w among an LP's vertices (lp 1: the Chebyshev LP, 0: the motion LP; best its optimum):
 * the optimal vertex nearest to w = 0 (PolygonRule.decide). POLYGON_AMBIGUOUS where the engine's own
 * answer may be another point: where it takes the Chebyshev LP's point (a ball neither thin nor
 * capped: _admissible_in_w's `unique`), another vertex within lp_near_optimal of the optimum (the LP
 * back-ends reach it to about a tenth of that, and may stop there); where it takes the rule's, another
 * optimal vertex as near to w = 0 to VERTEX_TOLERANCE (a tie round-off in the w basis breaks). */
static int polygon_choice(const ScratchPlan *plan, int lp, const double *best, const double (*vertex)[3],
                          const unsigned char *feasible, Py_ssize_t candidates, double *w) {
    double nearest = INFINITY, vt = plan->a.number[S_VERTEX];
    for (Py_ssize_t t = 0; t < candidates; t++) {
        const double *v = vertex[t];
        double sq = v[0] * v[0] + v[1] * v[1];
        if (feasible[t] && v[2] >= best[lp] - vt && sq < nearest) {
            nearest = sq, w[0] = v[0], w[1] = v[1];
        }
    }
    int own = lp == 1 && best[1] < plan->a.number[S_CAP] * (1.0 - plan->a.number[S_CAPPED]);
    double floor = own ? best[lp] - plan->a.number[S_NEAR] : best[lp] - vt;
    double tie = own ? 0.0 : vt * (nearest > 1.0 ? nearest : 1.0);
    return other_vertex(plan, vertex, feasible, candidates, floor, nearest, tie, w) ? POLYGON_AMBIGUOUS
                                                                                  : POLYGON_INSIDE;
}

/* frcontrol.ambiguity_polygon's PolygonRule, built and decided at once for rows a_i w <= h_i (a (rows,
 * 2), normalised in (u, w)): POLYGON_INSIDE with w (the Chebyshev centre, or the motion LP's vertex in
 * a thin set; on an optimal face its vertex nearest to w = 0), POLYGON_OUTSIDE when no w moves as the
 * mode says, POLYGON_NO_RULE when the rule cannot be built (more than polygon_max_rows rows, live rows
 * not spanning the plane: the LPs decide), POLYGON_AMBIGUOUS when the engine's w may be another point
 * (polygon_choice), which only the general path gives. Without any row (every contact of the mode
 * separating with no row on its acceleration, or none in contact: RHex in the air), every w is
 * admissible and the engine's LPs, which nothing moves from their start, report w = 0. */
static int polygon_rule(const ScratchPlan *plan, const double *a, const double *h, const unsigned char *mo,
                        Py_ssize_t rows, double *w) {
    double unit[POLYGON_ROWS_CAP][2], norms[POLYGON_ROWS_CAP], R[POLYGON_ROWS_CAP + 2][3], b[POLYGON_ROWS_CAP + 2];
    double vertex[2][POLYGON_CANDIDATES][3], best[2], tol = plan->a.number[S_DOMAIN];
    unsigned char feasible[2][POLYGON_CANDIDATES];
    Py_ssize_t live[POLYGON_ROWS_CAP], count = 0, candidates = 0;
    if (rows > plan->polygon_rows) {
        return POLYGON_NO_RULE;
    }
    if (rows == 0) { /* nothing bounds w: the engine's LPs answer their start, the centre nearest to w = 0 */
        w[0] = w[1] = 0.0;
        return POLYGON_INSIDE;
    }
    int ok = polygon_rows(plan, a, h, mo, rows, unit, norms, live, &count);
    if (ok != POLYGON_INSIDE) {
        return ok;
    }
    int moving = 0;
    for (int lp = 0; lp < 2; lp++) { /* the motion LP (t in [0, 1]), then the Chebyshev LP (r in [0, cap]) */
        for (Py_ssize_t i = 0; i < count; i++) {
            int motion = mo[live[i]] != 0;
            moving |= motion;
            R[i][0] = unit[i][0], R[i][1] = unit[i][1], R[i][2] = lp == 0 ? (double)motion : 1.0;
            b[i] = (h[live[i]] + (lp == 0 && motion ? 0.0 : tol)) / norms[i];
        }
        R[count][0] = R[count][1] = R[count + 1][0] = R[count + 1][1] = 0.0;
        R[count][2] = 1.0, R[count + 1][2] = -1.0;
        b[count] = lp == 0 ? 1.0 : plan->a.number[S_CAP], b[count + 1] = 0.0;
        best[lp] = polygon_lp((const double (*)[3])R, b, count + 2, plan, vertex[lp], feasible[lp], &candidates);
    }
    if (best[0] == -INFINITY || (best[0] <= tol && moving)) {
        return POLYGON_OUTSIDE; /* the motion LP: infeasible, or no w moving as the mode says */
    }
    int lp = best[1] > tol ? 1 : 0;
    return polygon_choice(plan, lp, best, (const double (*)[3])vertex[lp], feasible[lp], candidates, w);
}

/* Whether rebalance_undecided may balance the mode (needs_balancing: a sliding contact, L or R, whose mu
 * is above balancing_friction). */
static int balanced(const ScratchPlan *plan, const long long *letters, Py_ssize_t k) {
    const double *mu = plan->a.data[S_MU];
    for (Py_ssize_t i = 0; i < k; i++) {
        if ((letters[i] == LETTER_L || letters[i] == LETTER_R) && mu[i] > plan->a.number[S_BALANCING]) {
            return 1;
        }
    }
    return 0;
}

/* deficient_mode's arrays, in one block (deficient_scratch). */
typedef struct {
    double *memory;                 /* the block (w->deficient) */
    double *B;                      /* [S^T; 0] (nx, m) */
    double *basis, *T, *Bp, *cp, *E, *e, *X_u, *x0, *X_w, *info, *a, *h;
    double *Xc_u, *xc0, *Xc_w;      /* the responses over the nonzero columns (compact_certified) */
    long long *kept, *cols, *live;  /* live: the nonzero columns of the mode's A */
    unsigned char *mo;
    QRScratch r;
} Deficient;

/* The block of deficient_mode's arrays; -1 with an error set. */
static int deficient_scratch(const Problem *p, Deficient *d) {
    Py_ssize_t nx = p->nx, m = p->m, rows = INEQUALITY_ROWS * p->k, P = MAX_DEFICIENT_P;
    Py_ssize_t qr = nx * nx + nx + nx * (m + 1) + nx * (nx + m + 1) + 2 * nx + 2 * nx + m + 1;
    Py_ssize_t size = nx * m + 2 * nx * nx + 3 * nx + nx * m + nx + P * m + P + qr + 2 * (nx * m + nx + nx * P) +
                      BY_ROWS_INFO + (P + 1) * rows + rows + 1;
    double *at = d->memory = PyMem_Malloc((size_t)size * sizeof(double));
    if (at == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    d->B = at, at += nx * m;
    d->basis = at, at += nx * nx;
    d->T = at, at += nx * nx;
    d->kept = (long long *)at, at += nx;
    d->cols = (long long *)at, at += nx;
    d->live = (long long *)at, at += nx;
    d->Bp = at, at += nx * m;
    d->cp = at, at += nx;
    d->E = at, at += P * m;
    d->e = at, at += P;
    d->r = (QRScratch){0, nx, m, at, NULL, NULL, NULL, NULL, NULL, NULL}, at += qr;
    d->X_u = at, at += nx * m;
    d->x0 = at, at += nx;
    d->X_w = at, at += nx * P;
    d->Xc_u = at, at += nx * m;
    d->xc0 = at, at += nx;
    d->Xc_w = at, at += nx * P;
    d->info = at, at += BY_ROWS_INFO;
    d->a = at, at += P * rows;
    d->h = at, at += rows;
    d->mo = (unsigned char *)at;
    for (Py_ssize_t i = 0; i < nx; i++) {
        for (Py_ssize_t j = 0; j < m; j++) {
            d->B[i * m + j] = i < p->n ? p->input_map[i * m + j] : 0.0;
        }
    }
    return 0;
}

/* by_rows_system on the mode's A without its exactly zero columns (their unknowns are free: exact null
 * directions, which the SVD's null space holds, as unit vectors, the scaling of a zero column being 1)
 * and B', c': X_u, x_0 (0 at a zero column, as the minimum-norm solution) and X_w (nx, p), the
 * reduced system's null space first, then a unit vector per zero column. A zero column changes no
 * row's or other column's largest entry, so the reduced system's scalings are assemble's, and its
 * ||A_hat||_F (info[4]) is the whole A_hat's. */
static void compact_certified(const Scratch *s, const Problem *p, Deficient *d, Py_ssize_t q) {
    Py_ssize_t nx = p->nx, m = p->m, pdim = nx - q, cols = 0;
    for (Py_ssize_t j = 0; j < nx; j++) {
        int zero = 1;
        for (Py_ssize_t i = 0; i < nx && zero; i++) {
            zero = s->A[i * nx + j] == 0.0;
        }
        if (!zero) {
            d->live[cols++] = j;
        }
    }
    for (Py_ssize_t i = 0; i < nx; i++) { /* the reduced A (nx, cols), in T */
        for (Py_ssize_t c = 0; c < cols; c++) {
            d->T[i * cols + c] = s->A[i * nx + d->live[c]];
        }
    }
    QRScratch *r = &d->r;
    r->rows = q, r->nx = cols, r->tau = r->M + cols * q, r->V = r->tau + q, r->Y = r->V + cols * (m + 1);
    r->r = r->Y + q * (q + m + 1), r->s = r->r + nx, r->work = r->s + cols;
    by_rows_system(r, nx, d->T, d->Bp, d->cp, d->kept, 1.0 / (p->margin * p->tolerance), r->r, d->Xc_u, d->xc0,
                   d->Xc_w, d->info);
    Py_ssize_t own = cols - q; /* the reduced system's null directions (its X_w: (cols, own)) */
    memset(d->X_u, 0, (size_t)(nx * m) * sizeof(double));
    memset(d->x0, 0, (size_t)nx * sizeof(double));
    memset(d->X_w, 0, (size_t)(nx * pdim) * sizeof(double));
    for (Py_ssize_t c = 0; c < cols; c++) {
        Py_ssize_t i = d->live[c];
        memcpy(d->X_u + i * m, d->Xc_u + c * m, (size_t)m * sizeof(double));
        d->x0[i] = d->xc0[c];
        for (Py_ssize_t t = 0; t < own; t++) {
            d->X_w[i * pdim + t] = d->Xc_w[c * own + t];
        }
    }
    for (Py_ssize_t j = 0, t = own, c = 0; j < nx && t < pdim; j++) {
        if (c < cols && d->live[c] == j) {
            c++;
        } else {
            d->X_w[j * pdim + t++] = 1.0;
        }
    }
}

/* The mode in s with q of its nx rows kept, certified by them (p = nx - q): 1 with its X_u, x_0 and
 * X_w (nx, p) in d and whether its consistency rows hold at u in *consistent; -1 when a check fails or
 * the columns' rank is not q (the general path). */
static int deficient_certified(const ScratchPlan *plan, const Scratch *s, const Problem *p, Deficient *d,
                               Py_ssize_t q, int *consistent) {
    Py_ssize_t nx = p->nx, m = p->m, pdim = nx - q;
    if (left_null(s->A_hat, nx, q, d->T, d->basis, d->cols) != 0) {
        return -1;
    }
    const double *L = d->basis + q * nx;
    double scale = projected(s, d->B, nx, m, L, pdim, d->Bp, d->cp, d->E, d->e);
    compact_certified(s, p, d, q);
    if (!by_rows_ok(plan, d->info, nx, nx, s->A_hat, L, pdim)) {
        return -1;
    }
    *consistent = consistent_rows(d->E, d->e, pdim, m, scale, p->u, plan->a.number[S_CONSISTENCY],
                                  p->domain_tolerance);
    return 1;
}

/* Mode `mode` (NOT_CERTIFIED) certified by its rows and decided (DEFICIENT_DECIDED), or left to the
 * general path at this state (DEFICIENT_STATE) or at this input (DEFICIENT_INPUT: polygon_rule). */
static int deficient_mode(const ScratchPlan *plan, ScratchWork *w, const Problem *p, Py_ssize_t mode,
                          Deficient *d) {
    Py_ssize_t nx = p->nx, k = p->k;
    const long long *letters = p->letters + mode * k;
    if (balanced(plan, letters, k)) {
        return DEFICIENT_STATE;
    }
    Scratch *s = &w->s;
    assemble(p, letters, w->Su, s);
    Py_ssize_t q = independent_rows(s->A_hat, nx, d->basis, d->kept), pdim = nx - q;
    int consistent = 0;
    if (pdim < 1 || pdim > MAX_DEFICIENT_P || deficient_certified(plan, s, p, d, q, &consistent) < 0) {
        return DEFICIENT_STATE;
    }
    Ranked ranked = {.radius_cap = plan->a.number[S_CAP], .output_tolerance = plan->a.number[S_OUTPUT]};
    Py_ssize_t rows = sliced_rows(p, letters, pdim, d->X_u, d->x0, d->X_w, d->a, d->h, d->mo);
    double *wm = w->w + MAX_DEFICIENT_P * mode;
    int found = pdim == 1 ? interval(p, &ranked, rows, d->a, d->h, d->mo, wm) ? POLYGON_INSIDE : POLYGON_OUTSIDE
                          : polygon_rule(plan, d->a, d->h, d->mo, rows, wm);
    if (found == POLYGON_NO_RULE) { /* (the state's rows, whatever the input) */
        return DEFICIENT_STATE;
    }
    if (found == POLYGON_AMBIGUOUS && consistent) {
        return DEFICIENT_INPUT;
    }
    p->status[mode] = CERTIFIED_INADMISSIBLE;
    if (consistent && found == POLYGON_INSIDE) {
        p->status[mode] = CERTIFIED_ADMISSIBLE;
        w->pdims[mode] = (signed char)pdim;
        w->moves[mode] = moved_by(p, &ranked, d->X_w, pdim);
        finish(p, letters, s, d->X_u, d->x0, d->X_w, pdim, wm, p->x + mode * nx, &p->residual[mode],
               &p->violation[mode]);
    }
    return DEFICIENT_DECIDED;
}

/* Every NOT_CERTIFIED mode by deficient_mode: DEFICIENT_DECIDED when all are decided, DEFICIENT_STATE
 * when one is left to the general path at this state (whatever the others), else DEFICIENT_INPUT when one
 * is at this input; -1 with an error set. */
static int deficient_modes(const ScratchPlan *plan, ScratchWork *w, Problem *p) {
    Deficient d = {0};
    int decided = DEFICIENT_DECIDED;
    for (Py_ssize_t mode = 0; mode < p->count; mode++) {
        w->moves[mode] = -1, w->pdims[mode] = 0;
    }
    for (Py_ssize_t mode = 0; mode < p->count && decided != DEFICIENT_STATE; mode++) {
        if (p->status[mode] != NOT_CERTIFIED) {
            continue;
        }
        if (d.memory == NULL && deficient_scratch(p, &d)) {
            return -1;
        }
        int one = deficient_mode(plan, w, p, mode, &d);
        decided = one == DEFICIENT_DECIDED ? decided : one;
    }
    PyMem_Free(d.memory);
    return decided;
}

/* The admissible modes' solutions, in mode order, appended to `found`; -1 with an error set. */
static int scratch_found(const ScratchPlan *plan, const ScratchWork *w, const Problem *p, PyObject *found) {
    Py_ssize_t n = p->n, k = p->k, nx = p->nx;
    const double *JN = w->job.rows, *JT = w->job.rows + k * n, *values = w->job.values;
    double acc[2 * MAX_SCRATCH_CONTACTS];
    char name[MAX_SCRATCH_CONTACTS + 1];
    for (Py_ssize_t mode = 0; mode < p->count; mode++) {
        if (p->status[mode] != CERTIFIED_ADMISSIBLE) {
            continue;
        }
        const double *x = p->x + mode * nx;
        for (Py_ssize_t i = 0; i < k; i++) {
            double an = 0.0, at = 0.0;
            for (Py_ssize_t c = 0; c < n; c++) {
                an += JN[i * n + c] * x[c];
                at += JT[i * n + c] * x[c];
            }
            acc[i] = an + values[3 * k + i];
            acc[k + i] = at + values[4 * k + i];
            name[i] = "SLRF"[p->letters[mode * k + i]];
        }
        int moves = w->moves[mode], pdim = w->pdims[mode];
        PyObject *outputs = PyTuple_GET_ITEM(plan->outputs, pdim ? moves : MOVES_NONE);
        PyObject *mode_name = PyUnicode_FromStringAndSize(name, k);
        PyObject *solution = mode_name ? make_solution(&plan->mk, mode_name, outputs, pdim, x, acc,
                                                       w->w + MAX_DEFICIENT_P * mode, p->residual[mode],
                                                       p->violation[mode]) : NULL;
        Py_XDECREF(mode_name);
        if (solution == NULL || PyList_Append(found, solution) != 0) {
            Py_XDECREF(solution);
            return -1;
        }
        Py_DECREF(solution);
    }
    return 0;
}

/* The answer from the state in w: the list of solutions, None (the general path answers) or False (it
 * does, and a mode is left to the SVD: the state's A decides that, not the input). */
static PyObject *scratch_answer(const ScratchPlan *plan, const double *u, ScratchWork *w) {
    Py_ssize_t n = plan->mk.n, k = plan->mk.k;
    int mask[MAX_SCRATCH_CONTACTS];
    const double *values = w->job.values;
    if (plan->declines || !all_finite(w->job.mass, n * n + n) || !all_finite(w->job.rows, 2 * k * n) ||
        !all_finite(values + k, 4 * k)) { /* the general path says which number is bad */
        return Py_NewRef(Py_None);
    }
    w->count = k > MAX_SCRATCH_CONTACTS ? -1 : allowed_letters(values + k, values + 2 * k, k,
                                                              plan->a.number[S_VELOCITY], plan->max_modes, mask);
    if (w->count < 0) {
        return Py_NewRef(Py_None);
    }
    Problem p;
    if (scratch_modes(plan, u, mask, w, &p)) {
        return NULL;
    }
    int decided = deficient_modes(plan, w, &p);
    if (decided < 0) {
        return NULL;
    }
    if (decided == DEFICIENT_INPUT) { /* this input's */
        return Py_NewRef(Py_None);
    }
    if (decided == DEFICIENT_STATE) { /* the state's, whatever the input */
        return Py_NewRef(Py_False);
    }
    PyObject *found = PyList_New(0);
    if (found != NULL && scratch_found(plan, w, &p, found)) {
        Py_CLEAR(found);
    }
    return found;
}

/* scratch_solutions(plan, v, inputs) -> [solution, ...], None or False (see above). */
static PyObject *scratch_solutions(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 3) {
        PyErr_Format(kernel_error, "scratch_solutions takes 3 arguments, got %zd", nargs);
        return NULL;
    }
    ScratchPlan *plan = scratch_plan_of(args[0]);
    if (plan == NULL) {
        PyErr_SetString(kernel_error, "scratch_solutions: the first argument is not a scratch_plan");
        return NULL;
    }
    Buffer v = {0}, b[3];
    memset(b, 0, sizeof(b));
    Py_ssize_t v_shape[1] = {plan->mk.n};
    ScratchWork w;
    memset(&w, 0, sizeof(w));
    PyObject *result = NULL;
    double *u = PyMem_Malloc((size_t)(plan->in.m + 1) * sizeof(double));
    if (u == NULL) {
        PyErr_NoMemory();
    } else if (!plain_input(&plan->in, args[2], u)) {
        result = Py_NewRef(Py_None);
    } else if (take_strided(args[1], &v, "v", 1, v_shape) == 0 && scratch_state(plan, &v.view, &w, b) == 0) {
        result = scratch_answer(plan, u, &w);
    }
    PyMem_Free(u);
    free_work(&w);
    release(&v, 1);
    release(b, 3);
    return result;
}

/* problem_solutions(plan, mass, jacobian_normal, jacobian_tangent, drift_normal, drift_tangent,
 * normal_velocities, tangential_velocities, bias, inputs) -> [solution, ...], None or False: as
 * scratch_solutions, from a contact problem's arrays (any strides) on a plan made without a robot. */
#define PROBLEM_SOLUTION_ARGS 10
static const Arg problem_solutions_table[PROBLEM_SOLUTION_ARGS] = {
    {"plan", 'o', 0, {0}, 0}, {"mass", 's', 2, {DIM_N, DIM_S}, 0}, {"jacobian_normal", 's', 2, {DIM_K, DIM_N}, 0},
    {"jacobian_tangent", 's', 2, {DIM_K, DIM_N}, 0}, {"drift_normal", 's', 1, {DIM_K}, 0},
    {"drift_tangent", 's', 1, {DIM_K}, 0}, {"normal_velocities", 's', 1, {DIM_K}, 0},
    {"tangential_velocities", 's', 1, {DIM_K}, 0}, {"bias", 's', 1, {DIM_N}, 0}, {"inputs", 'o', 0, {0}, 0}};
static const Signature problem_solutions_signature = {"problem_solutions", PROBLEM_SOLUTION_ARGS,
                                                      problem_solutions_table, NULL};

/* The problem's arrays (parsed in a) into w->job's; -1 with an error set. */
static int problem_state(const ScratchPlan *plan, const Args *a, ScratchWork *w) {
    Py_ssize_t n = plan->mk.n, k = plan->mk.k;
    if (a->dim[DIM_N] != n || a->dim[DIM_S] != n || a->dim[DIM_K] != k) {
        PyErr_Format(kernel_error, "problem_solutions: the arrays are of n = %zd, k = %zd; the plan's of n = %zd, "
                     "k = %zd", a->dim[DIM_N], a->dim[DIM_K], n, k);
        return -1;
    }
    if (state_block(plan, w)) {
        return -1;
    }
    const StateJob *job = &w->job;
    const Buffer *b = a->buffer;
    for (Py_ssize_t i = 0; i < n; i++) {
        for (Py_ssize_t c = 0; c < n; c++) {
            job->mass[i * n + c] = at2(&b[1].view, i, c);
        }
        job->bias[i] = at1(&b[8].view, i);
    }
    for (Py_ssize_t i = 0; i < k; i++) {
        for (Py_ssize_t c = 0; c < n; c++) {
            job->rows[i * n + c] = at2(&b[2].view, i, c);
            job->rows[(k + i) * n + c] = at2(&b[3].view, i, c);
        }
        job->values[k + i] = at1(&b[6].view, i);
        job->values[2 * k + i] = at1(&b[7].view, i);
        job->values[3 * k + i] = at1(&b[4].view, i);
        job->values[4 * k + i] = at1(&b[5].view, i);
    }
    return 0;
}

static PyObject *problem_solutions(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    ScratchWork w;
    memset(&w, 0, sizeof(w));
    PyObject *result = NULL;
    double *u = NULL;
    if (parse(&problem_solutions_signature, args, nargs, &a) == 0) {
        ScratchPlan *plan = scratch_plan_of(args[0]);
        if (plan == NULL || plan->robot != Py_None) {
            PyErr_SetString(kernel_error, "problem_solutions: the first argument is not a problem's scratch_plan");
        } else if ((u = PyMem_Malloc((size_t)(plan->in.m + 1) * sizeof(double))) == NULL) {
            PyErr_NoMemory();
        } else if (!plain_input(&plan->in, args[PROBLEM_SOLUTION_ARGS - 1], u)) {
            result = Py_NewRef(Py_None);
        } else if (problem_state(plan, &a, &w) == 0) {
            result = scratch_answer(plan, u, &w);
        }
    }
    PyMem_Free(u);
    free_work(&w);
    release_args(&a);
    return result;
}

/* environment_value(name) -> str: the process environment's value of `name`, "" when unset (C's
 * getenv, which os.environ's changes keep current): frcontrol.kernel's one read of FRC_KERNEL,
 * without the cost of os.environ's lookup. */
static PyObject *environment_value(PyObject *self, PyObject *name) {
    (void)self;
    if (!PyBytes_Check(name)) {
        PyErr_SetString(kernel_error, "environment_value: the name must be bytes");
        return NULL;
    }
    const char *value = getenv(PyBytes_AS_STRING(name));
    return PyUnicode_DecodeFSDefault(value != NULL ? value : "");
}

/* ------------------------------------------------------------------------------------------------
 * lemke: the pivots of frcontrol.lcp's lexicographic Lemke method (_LemkeTableau, _lemke_pivots),
 * the reference it reproduces pivot for pivot. The tableau [I, -M, -1 | q] (n rows, 2n + 2
 * columns: w, z, z0, the right side) is pivoted as there: the row divided by its pivot, then
 * table_i -= table_ic table_row for every other row. The ratio test is lexicographic on the rows
 * [B^-1 q, B^-1] / d, ties within TIE * (|B^-1| |q|)_i / d_i (first key) and TIE max_k |B^-1_ik| / d_i
 * (the others); z0's row is taken whenever it ties on the first key. The basis, its matrix
 * [I, -M, -1][:, basis] and the final right side go to the caller (its LU solve recomputes the
 * point); the only sum is |B^-1| |q|, a tie width, added in index order. */
enum { LEMKE_SOLVED = 0, LEMKE_RAY = 1, LEMKE_MAX_PIVOTS = 2 };

typedef struct {
    Py_ssize_t n, cols;
    double *table; /* n x cols, cols = 2n + 2 */
    double *absq, *keys, *widths, *divisor;
    Py_ssize_t *rows, *kept;
    long long *basis;
    double tie;
} Lemke;

static void lemke_pivot(Lemke *L, Py_ssize_t row, Py_ssize_t column) {
    Py_ssize_t cols = L->cols;
    double *r = L->table + row * cols;
    double pivot = r[column];
    for (Py_ssize_t j = 0; j < cols; j++) {
        r[j] /= pivot;
    }
    for (Py_ssize_t i = 0; i < L->n; i++) {
        if (i == row) {
            continue;
        }
        double *t = L->table + i * cols;
        double factor = t[column];
        for (Py_ssize_t j = 0; j < cols; j++) {
            t[j] -= factor * r[j];
        }
    }
    L->basis[row] = column;
}

/* _LemkeTableau.choose_row and _lexicographic_min_row over the eligible rows[0..count). */
static Py_ssize_t lemke_choose_row(Lemke *L, Py_ssize_t count, Py_ssize_t preferred) {
    Py_ssize_t n = L->n, cols = L->cols, *rows = L->rows, *kept = L->kept;
    for (Py_ssize_t c = 0; c < count; c++) {
        Py_ssize_t i = rows[c];
        const double *t = L->table + i * cols;
        double scale0 = 0.0, scale1 = 0.0;
        for (Py_ssize_t k = 0; k < n; k++) {
            double a = fabs(t[k]);
            scale0 += a * L->absq[k];
            scale1 = a > scale1 ? a : scale1;
        }
        L->widths[2 * i] = L->tie * scale0 / L->divisor[i];
        L->widths[2 * i + 1] = L->tie * scale1 / L->divisor[i];
    }
    for (Py_ssize_t column = 0; column <= n; column++) {
        Py_ssize_t best = 0;
        for (Py_ssize_t c = 0; c < count; c++) {
            Py_ssize_t i = rows[c];
            const double *t = L->table + i * cols;
            L->keys[i] = (column == 0 ? t[cols - 1] : t[column - 1]) / L->divisor[i];
            if (c > 0 && L->keys[i] < L->keys[rows[best]]) {
                best = c;
            }
        }
        Py_ssize_t b = rows[best], width = column == 0 ? 0 : 1, kept_count = 0, has_preferred = 0;
        for (Py_ssize_t c = 0; c < count; c++) {
            Py_ssize_t i = rows[c];
            double wi = L->widths[2 * i + width], wb = L->widths[2 * b + width];
            if (L->keys[i] <= L->keys[b] + (wi > wb ? wi : wb)) {
                kept[kept_count++] = i;
                has_preferred |= i == preferred;
            }
        }
        memcpy(rows, kept, (size_t)kept_count * sizeof(Py_ssize_t));
        count = kept_count;
        if (column == 0 && has_preferred) {
            return preferred;
        }
        if (count == 1) {
            break;
        }
    }
    return rows[0];
}

/* The pivots from the first (z0 entering) to z0 leaving, a ray or the pivot limit. */
static int lemke_run(Lemke *L, long long max_pivots, double pivot_tolerance, long long *pivots) {
    Py_ssize_t n = L->n, cols = L->cols, z0 = 2 * n;
    for (Py_ssize_t i = 0; i < n; i++) {
        L->rows[i] = i;
        L->divisor[i] = 1.0;
    }
    Py_ssize_t row = lemke_choose_row(L, n, -1);
    long long leaving = L->basis[row];
    lemke_pivot(L, row, z0);
    *pivots = 1;
    while (leaving != z0) {
        Py_ssize_t entering = leaving < n ? leaving + n : leaving - n;
        double largest = 0.0;
        int nan = 0;
        for (Py_ssize_t i = 0; i < n; i++) {
            double a = fabs(L->table[i * cols + entering]);
            nan |= isnan(a);
            largest = a > largest ? a : largest;
        }
        Py_ssize_t count = 0;
        for (Py_ssize_t i = 0; i < n && largest > 0 && !nan; i++) {
            double d = L->table[i * cols + entering];
            if (d > pivot_tolerance * largest) {
                L->rows[count++] = i;
            }
        }
        if (count == 0) {
            return LEMKE_RAY;
        }
        if (*pivots >= max_pivots) {
            return LEMKE_MAX_PIVOTS;
        }
        Py_ssize_t preferred = -1;
        for (Py_ssize_t i = 0; i < n && preferred < 0; i++) {
            preferred = L->basis[i] == z0 ? i : -1;
        }
        for (Py_ssize_t i = 0; i < n; i++) {
            double d = L->table[i * cols + entering];
            L->divisor[i] = d > 0 ? d : 1.0;
        }
        row = lemke_choose_row(L, count, preferred);
        leaving = L->basis[row];
        lemke_pivot(L, row, entering);
        *pivots += 1;
    }
    return LEMKE_SOLVED;
}

static const Arg lemke_table[] = {
    {"M", 'd', 2, {DIM_N, DIM_N}, 0}, {"q", 'd', 1, {DIM_N}, 0}, {"basis", 'q', 1, {DIM_N}, WRITE},
    {"matrix", 'd', 2, {DIM_N, DIM_N}, WRITE}, {"rhs", 'd', 1, {DIM_N}, WRITE}, {"max_pivots", 'i', 0, {0}, 0},
    {"pivot_tolerance", 'f', 0, {0}, 0}, {"tie", 'f', 0, {0}, 0}};
static const Signature lemke_signature = {"lemke", 8, lemke_table, NULL};

static PyObject *lemke(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    double *work = NULL;
    Py_ssize_t *index = NULL;
    if (parse(&lemke_signature, args, nargs, &a)) {
        goto done;
    }
    Py_ssize_t n = a.dim[DIM_N];
    long long max_pivots = a.integer[5];
    double pivot_tolerance = a.number[6], tie = a.number[7];
    Py_ssize_t cols = 2 * n + 2;
    work = PyMem_Malloc((size_t)(n * cols + 5 * n + 1) * sizeof(double));
    index = PyMem_Malloc((size_t)(2 * n + 1) * sizeof(Py_ssize_t));
    if (work == NULL || index == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    const double *M = a.data[0], *q = a.data[1];
    Lemke L = {n, cols, work, work + n * cols, work + n * cols + n, work + n * cols + 2 * n,
               work + n * cols + 4 * n, index, index + n, a.data[2], tie};
    for (Py_ssize_t i = 0; i < n; i++) {
        double *t = L.table + i * cols;
        for (Py_ssize_t j = 0; j < n; j++) {
            t[j] = i == j ? 1.0 : 0.0;
            t[n + j] = -M[i * n + j];
        }
        t[2 * n] = -1.0;
        t[2 * n + 1] = q[i];
        L.absq[i] = fabs(q[i]);
        L.basis[i] = i;
    }
    long long pivots = 0;
    int status = lemke_run(&L, max_pivots, pivot_tolerance, &pivots);
    double *matrix = a.data[3], *rhs = a.data[4];
    for (Py_ssize_t i = 0; i < n; i++) {
        rhs[i] = L.table[i * cols + cols - 1];
        for (Py_ssize_t r = 0; r < n; r++) {
            long long c = L.basis[r];
            matrix[i * n + r] = c < n ? (c == i ? 1.0 : 0.0) : c < 2 * n ? -M[i * n + (c - n)] : -1.0;
        }
    }
    result = Py_BuildValue("(iL)", status, pivots);
done:
    PyMem_Free(work);
    PyMem_Free(index);
    release_args(&a);
    return result;
}

/* coulomb_matrix: frcontrol.simulation.impact._coulomb_matrix of the Delassus matrix W (2c, 2c)
 * scaled by m_ref (each entry W_ij m_ref, negated where the block is): the LCP matrix (4c, 4c) in
 * z = (p_N, p_T+, p_T-, sigma), written into out, entry for entry as there. */
static const Arg coulomb_table[] = {
    {"W", 'd', 2, {DIM_S, DIM_S}, 0}, {"m_ref", 'f', 0, {0}, 0}, {"mu", 'd', 1, {DIM_K}, 0},
    {"out", 'd', 2, {DIM_A, DIM_A}, WRITE}};
static void derive_coulomb(Py_ssize_t *dim) { /* out: (4c, 4c) */
    derive_dim(dim, DIM_A, dim[DIM_K] >= 0, 4 * dim[DIM_K]);
}
static const Signature coulomb_signature = {"coulomb_matrix", 4, coulomb_table, derive_coulomb};

static PyObject *coulomb_matrix(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    if (parse(&coulomb_signature, args, nargs, &a) || expect_dim(a.dim[DIM_S], 2 * a.dim[DIM_K], "W", 0)) {
        goto done;
    }
    Py_ssize_t c = a.dim[DIM_K];
    double m_ref = a.number[1];
    const double *W = a.data[0], *mu = a.data[2];
    double *out = a.data[3];
    Py_ssize_t n = 4 * c, w = 2 * c;
    memset(out, 0, (size_t)(n * n) * sizeof(double));
    for (Py_ssize_t i = 0; i < c; i++) {
        for (Py_ssize_t j = 0; j < c; j++) {
            double nn = W[i * w + j] * m_ref, nt = W[i * w + c + j] * m_ref;
            double tn = W[(c + i) * w + j] * m_ref, tt = W[(c + i) * w + c + j] * m_ref;
            double *row_n = out + i * n, *row_p = out + (c + i) * n, *row_m = out + (2 * c + i) * n;
            row_n[j] = nn, row_n[c + j] = nt, row_n[2 * c + j] = -nt;
            row_p[j] = tn, row_p[c + j] = tt, row_p[2 * c + j] = -tt;
            row_m[j] = -tn, row_m[c + j] = -tt, row_m[2 * c + j] = tt;
        }
        out[(c + i) * n + 3 * c + i] = 1.0;
        out[(2 * c + i) * n + 3 * c + i] = 1.0;
        out[(3 * c + i) * n + i] = mu[i];
        out[(3 * c + i) * n + c + i] = -1.0;
        out[(3 * c + i) * n + 2 * c + i] = -1.0;
    }
    result = Py_NewRef(Py_None);
done:
    release_args(&a);
    return result;
}

/* lcp_check: frcontrol.lcp._verified's numbers for a candidate z of the LCP (M, q) with its
 * w = M z + q (computed by the caller, NumPy's product): the residual max_i |min(z_i, w_i)| and the
 * largest row bound, and whether every row is within its bound: tolerance * max((|M| |z|)_i,
 * ||q||_inf) (lcp_row_tolerances), or, for an enumerated candidate, tolerance * ||q||_inf
 * (lcp_enumeration_tolerance). The residual is NumPy's exactly; the bounds' sums run in index
 * order (the same to round-off); a NaN anywhere makes the residual NaN and the check fail. */
static const Arg lcp_table[] = {
    {"M", 'd', 2, {DIM_N, DIM_N}, 0}, {"q", 'd', 1, {DIM_N}, 0}, {"z", 'd', 1, {DIM_N}, 0},
    {"w", 'd', 1, {DIM_N}, 0}, {"tolerance", 'f', 0, {0}, 0}, {"enumerated", 't', 0, {0}, 0}};
static const Signature lcp_signature = {"lcp_check", 6, lcp_table, NULL};

static PyObject *lcp_check_point(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    if (parse(&lcp_signature, args, nargs, &a)) {
        goto done;
    }
    Py_ssize_t n = a.dim[DIM_N];
    const double *M = a.data[0], *q = a.data[1], *z = a.data[2], *w = a.data[3];
    double tolerance = a.number[4];
    int enumerated = (int)a.integer[5];
    double floor = 0.0, residual = 0.0, bound = 0.0;
    int found = 1, nan = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        nan |= isnan(q[i]);
        floor = fabs(q[i]) > floor ? fabs(q[i]) : floor;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        double size = 0.0;
        for (Py_ssize_t j = 0; j < n; j++) {
            size += fabs(M[i * n + j]) * fabs(z[j]);
        }
        double natural = fabs(z[i] < w[i] ? z[i] : w[i]);
        double row = tolerance * (enumerated || floor > size ? floor : size);
        nan |= isnan(w[i]) || isnan(z[i]) || isnan(size);
        residual = natural > residual ? natural : residual;
        bound = row > bound ? row : bound;
        found &= natural <= row;
    }
    if (nan) {
        residual = bound = NAN;
        found = 0;
    }
    result = Py_BuildValue("(ddO)", residual, bound, found ? Py_True : Py_False);
done:
    release_args(&a);
    return result;
}

/* compliant_law: frcontrol.simulation.compliant.contact_forces without contact zones, entry for
 * entry as there (NumPy's maximum, sign and where; no sums): per contact the Kelvin-Voigt normal
 * force, the Coulomb slider's tangential force and stretch rate, and the status (0 open, 1 stick,
 * 2 slip). Inputs: gaps, v_N, v_T, the stretch s, mu, k_N, b_N, k_T, b_T (c,); outputs lam_N,
 * lam_T, rate (float64) and status (int64), (c,). */
static double numpy_sign(double x) {
    return isnan(x) ? x : x > 0.0 ? 1.0 : x < 0.0 ? -1.0 : 0.0;
}

static const Arg compliant_table[] = {
    {"gaps", 'd', 1, {DIM_K}, 0}, {"normal_velocities", 'd', 1, {DIM_K}, 0},
    {"tangential_velocities", 'd', 1, {DIM_K}, 0}, {"stretch", 'd', 1, {DIM_K}, 0}, {"mu", 'd', 1, {DIM_K}, 0},
    {"stiffness", 'd', 1, {DIM_K}, 0}, {"damping", 'd', 1, {DIM_K}, 0}, {"tangential_stiffness", 'd', 1, {DIM_K}, 0},
    {"tangential_damping", 'd', 1, {DIM_K}, 0}, {"lam_n", 'd', 1, {DIM_K}, WRITE}, {"lam_t", 'd', 1, {DIM_K}, WRITE},
    {"rate", 'd', 1, {DIM_K}, WRITE}, {"status", 'q', 1, {DIM_K}, WRITE}};
static const Signature compliant_signature = {"compliant_law", 13, compliant_table, NULL};

static PyObject *compliant_law(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    if (parse(&compliant_signature, args, nargs, &a)) {
        goto done;
    }
    Py_ssize_t c = a.dim[DIM_K];
    void *const *b = a.data;
    const double *gaps = b[0], *vn = b[1], *vt = b[2], *s = b[3], *mu = b[4], *k_n = b[5], *b_n = b[6];
    const double *k_t = b[7], *b_t = b[8];
    double *lam_n = b[9], *lam_t = b[10], *rate = b[11];
    long long *status = b[12];
    for (Py_ssize_t i = 0; i < c; i++) {
        double delta = -gaps[i], push = k_n[i] * delta - b_n[i] * vn[i];
        double normal = delta > 0.0 ? (0.0 >= push ? 0.0 : push) : 0.0; /* numpy.maximum(0, push) */
        double limit = mu[i] * normal, trial = k_t[i] * s[i] + b_t[i] * vt[i], sign = numpy_sign(trial);
        int stick = fabs(trial) <= limit;
        lam_n[i] = normal;
        lam_t[i] = stick ? -trial : -limit * sign;
        rate[i] = stick ? vt[i] : (limit * sign - k_t[i] * s[i]) / b_t[i];
        status[i] = normal > 0.0 ? (stick ? 1 : 2) : 0;
    }
    result = Py_NewRef(Py_None);
done:
    release_args(&a);
    return result;
}

/* ------------------------------------------------------------------------------------------------
 * held_verdict: frcontrol.stability.stable_verdicts' verdict on one rigid solution, where M has a
 * Cholesky factor (the reference: stability._held_spectrum and _signs, on _state_terms). The
 * solution's scales and tolerances, the impending checks and the held rows J_r and columns J_c
 * are the reference's (eig_tol to an ulp: Python's ** calls pow); D = J_r M^-1 J_c^T by the factor's two triangular
 * solves. One held row: D's one eigenvalue is D (the reference's closed form). Two held rows of
 * rank 2 (their Gram matrix's smaller eigenvalue above `separation` times its larger, far from the rank
 * tolerance): D's eigenvalues, which the reference's row-space restriction U^T D U shares, by the
 * 2 x 2 closed form. Returns VERDICT_STABLE, VERDICT_UNSTABLE or VERDICT_NONE (not analysable),
 * or VERDICT_DECLINED where the reference decides: more rows, a rank the Gram matrix cannot tell,
 * a number that is not finite, a mode that does not fit (the reference words the error), more
 * than VERDICT_MAX_N coordinates, or an eigenvalue's real part within `band` times D's terms'
 * magnitude of the tolerance (the two computations sum in other orders).
 * ------------------------------------------------------------------------------------------------ */
enum { VERDICT_UNSTABLE = 0, VERDICT_STABLE = 1, VERDICT_NONE = -1, VERDICT_DECLINED = 2 };
enum { VERDICT_MAX_N = 32, VERDICT_MAX_ROWS = 2 };

typedef struct {
    const Py_buffer *factor, *jn, *jt, *mu, *vn, *vt, *lam_n, *lam_t, *a_n, *a_t, *dv;
    Py_ssize_t n, k;
    double vtol, mass_scale, bias_scale, force_rel, accel_rel, eig_rel, rank_rel, range_lo, range_hi, band;
    double separation; /* the Gram test's least ratio of eigenvalues (two rows of rank 2) */
} VerdictInput;

/* max(1, max |x|) over the entries of the given vectors (stability._scale_of); NaN when one is not finite. */
static double verdict_scale(const Py_buffer *const *vectors, const Py_ssize_t *counts, int how_many) {
    double scale = 1.0;
    for (int v = 0; v < how_many; v++) {
        for (Py_ssize_t i = 0; i < counts[v]; i++) {
            double x = fabs(at1(vectors[v], i));
            if (!isfinite(x)) {
                return NAN;
            }
            scale = x > scale ? x : scale;
        }
    }
    return scale;
}

enum { ROWS_IMPENDING = -1, ROWS_DECLINED = -2 };

/* The held rows (rows, n) and columns of the mode, as _constraint_rows: their count, ROWS_IMPENDING
 * at an impending change, or ROWS_DECLINED (more than two rows; held_verdict checked the letters). */
static int verdict_rows(const VerdictInput *in, const char *mode, double force_tol, double accel_tol,
                        double *rows, double *cols) {
    int r = 0, over = 0;
    Py_ssize_t n = in->n;
    for (Py_ssize_t i = 0; i < in->k; i++) {
        char letter = mode[i];
        double lam_n = at1(in->lam_n, i), mu = at1(in->mu, i);
        if (letter == 'S') {
            if (fabs(at1(in->vn, i)) <= in->vtol && fabs(at1(in->a_n, i)) <= accel_tol) {
                return ROWS_IMPENDING;
            }
            continue;
        }
        if (lam_n <= force_tol || (letter == 'F' && fabs(at1(in->lam_t, i)) >= mu * lam_n - force_tol) ||
            (letter != 'F' && fabs(at1(in->vt, i)) <= in->vtol && fabs(at1(in->a_t, i)) <= accel_tol)) {
            return ROWS_IMPENDING;
        }
        int take = letter == 'F' ? 2 : 1;
        if (r + take > VERDICT_MAX_ROWS) {
            over = 1; /* the reference decides, after the contacts left to check */
            continue;
        }
        double slide = letter == 'R' ? 1.0 * mu : -1.0 * mu; /* sign * mu[i], as the reference */
        for (Py_ssize_t j = 0; j < n; j++) {
            double normal = at2(in->jn, i, j), tangent = at2(in->jt, i, j);
            rows[r * n + j] = normal;
            cols[r * n + j] = letter == 'F' ? normal : normal - slide * tangent;
            if (letter == 'F') {
                rows[(r + 1) * n + j] = cols[(r + 1) * n + j] = tangent;
            }
        }
        r += take;
    }
    return over ? ROWS_DECLINED : r;
}

/* x = M^-1 b with M = U^T U, U the upper factor (LAPACK's potrs: U^T y = b, then U x = y). */
static void verdict_solve(const Py_buffer *factor, Py_ssize_t n, const double *b, double *x) {
    for (Py_ssize_t i = 0; i < n; i++) {
        double sum = b[i];
        for (Py_ssize_t j = 0; j < i; j++) {
            sum -= at2(factor, j, i) * x[j];
        }
        x[i] = sum / at2(factor, i, i);
    }
    for (Py_ssize_t i = n - 1; i >= 0; i--) {
        double sum = x[i];
        for (Py_ssize_t j = i + 1; j < n; j++) {
            sum -= at2(factor, i, j) * x[j];
        }
        x[i] = sum / at2(factor, i, i);
    }
}

/* The real parts of D's eigenvalues (r = 1 or 2; D row-major r x r) into re; 0, or ROWS_DECLINED
 * when they are not the reference's to round-off (its closed form's range; the Gram test of rank
 * 2). `slack` gets how far round-off may move them (a double root's real parts move by the
 * square root of the discriminant's round-off). */
static int verdict_real_parts(const VerdictInput *in, int r, const double *rows, const double *D, double size,
                              double j_scale, double *re, double *slack) {
    Py_ssize_t n = in->n;
    *slack = in->band * size;
    if (r == 1) {
        double d = fabs(D[0]);
        re[0] = D[0];
        return d > in->range_lo && d < in->range_hi ? 0 : ROWS_DECLINED;
    }
    double g00 = 0.0, g01 = 0.0, g11 = 0.0;
    for (Py_ssize_t j = 0; j < n; j++) {
        double x = rows[j] / j_scale, y = rows[n + j] / j_scale;
        g00 += x * x;
        g01 += x * y;
        g11 += y * y;
    }
    double half = 0.5 * (g00 + g11), gap = sqrt(0.25 * (g00 - g11) * (g00 - g11) + g01 * g01);
    double low = g00 * g11 - g01 * g01; /* the product of the Gram matrix's eigenvalues */
    if (!(half > 0.0) || low <= in->separation * (half + gap) * (half + gap)) {
        return ROWS_DECLINED;
    }
    double p = 0.5 * (D[0] - D[3]), mid = 0.5 * (D[0] + D[3]), disc = p * p + D[1] * D[2];
    if (disc >= 0.0) {
        double root = sqrt(disc), big = mid + copysign(root, mid);
        re[0] = big;
        re[1] = big != 0.0 ? (D[0] * D[3] - D[1] * D[2]) / big : mid - root;
    } else {
        re[0] = re[1] = mid;
    }
    if (fabs(disc) <= in->band * size * size) {
        *slack += sqrt(in->band) * size;
    }
    return 0;
}

/* D's componentwise round-off scale max_ab |J_r[a]| |U^-1| |U^-T| |J_c[b]|^T (U the upper factor):
 * both the reference's solve and verdict_solve err by a small multiple of eps times it. */
static void verdict_size(const Py_buffer *factor, Py_ssize_t n, int r, const double *rows, const double *cols,
                         double *size) {
    double inverse[VERDICT_MAX_N * VERDICT_MAX_N], t[VERDICT_MAX_N], s[VERDICT_MAX_N];
    for (Py_ssize_t j = 0; j < n; j++) { /* column j of U^-1: U y = e_j, upper triangular */
        for (Py_ssize_t i = n - 1; i >= 0; i--) {
            double sum = i == j ? 1.0 : 0.0;
            for (Py_ssize_t l = i + 1; l <= j; l++) {
                sum -= at2(factor, i, l) * inverse[l * n + j];
            }
            inverse[i * n + j] = i > j ? 0.0 : sum / at2(factor, i, i);
        }
    }
    *size = 0.0;
    for (int b = 0; b < r; b++) {
        for (Py_ssize_t i = 0; i < n; i++) { /* t = |U^-T| |J_c[b]|, then s = |U^-1| t */
            t[i] = 0.0;
            for (Py_ssize_t j = 0; j <= i; j++) {
                t[i] += fabs(inverse[j * n + i]) * fabs(cols[b * n + j]);
            }
        }
        for (Py_ssize_t i = 0; i < n; i++) {
            s[i] = 0.0;
            for (Py_ssize_t j = i; j < n; j++) {
                s[i] += fabs(inverse[i * n + j]) * t[j];
            }
        }
        for (int a = 0; a < r; a++) {
            double term = 0.0;
            for (Py_ssize_t i = 0; i < n; i++) {
                term += fabs(rows[a * n + i]) * s[i];
            }
            *size = term > *size ? term : *size;
        }
    }
}

/* The verdict of solution `mode` (module comment above held_verdict's table). */
static int verdict_of(const VerdictInput *in, const char *mode) {
    const Py_buffer *forces[2] = {in->lam_n, in->lam_t}, *motion[3] = {in->dv, in->a_n, in->a_t};
    Py_ssize_t force_counts[2] = {in->k, in->k}, motion_counts[3] = {in->n, in->k, in->k};
    double force_scale = verdict_scale(forces, force_counts, 2), accel_scale = verdict_scale(motion, motion_counts, 3);
    if (isnan(force_scale) || isnan(accel_scale) || !isfinite(in->bias_scale) || in->n > VERDICT_MAX_N) {
        return VERDICT_DECLINED;
    }
    force_scale = in->bias_scale > force_scale ? in->bias_scale : force_scale; /* max(scale, bias_scale) */
    double rows[VERDICT_MAX_ROWS * VERDICT_MAX_N], cols[VERDICT_MAX_ROWS * VERDICT_MAX_N];
    int r = verdict_rows(in, mode, in->force_rel * force_scale, in->accel_rel * accel_scale, rows, cols);
    if (r < 0 || r == 0) {
        return r == ROWS_IMPENDING ? VERDICT_NONE : r == 0 ? VERDICT_STABLE : VERDICT_DECLINED;
    }
    Py_ssize_t n = in->n;
    double j_r_size = 0.0, j_c_size = 0.0;
    for (Py_ssize_t e = 0; e < r * n; e++) {
        j_r_size = fabs(rows[e]) > j_r_size ? fabs(rows[e]) : j_r_size;
        j_c_size = fabs(cols[e]) > j_c_size ? fabs(cols[e]) : j_c_size;
    }
    double j_scale = j_r_size > j_c_size ? j_r_size : j_c_size;
    j_scale = j_scale > 1e-300 ? j_scale : 1e-300;
    if (!isfinite(j_scale) || (r == 1 && !(j_r_size > in->rank_rel * j_scale))) {
        return VERDICT_DECLINED; /* one row of rank 0: the reference's SVD decides */
    }
    double eig_tol = in->eig_rel * (j_scale * j_scale / in->mass_scale); /* Python's ** may differ by an ulp */
    double x[VERDICT_MAX_N], D[VERDICT_MAX_ROWS * VERDICT_MAX_ROWS], size = 0.0;
    for (int b = 0; b < r; b++) {
        verdict_solve(in->factor, n, cols + b * n, x);
        for (int a = 0; a < r; a++) {
            double sum = 0.0;
            for (Py_ssize_t j = 0; j < n; j++) {
                sum += rows[a * n + j] * x[j];
            }
            D[a * r + b] = sum;
        }
    }
    verdict_size(in->factor, n, r, rows, cols, &size);
    double re[VERDICT_MAX_ROWS], slack;
    int finite = isfinite(size) && isfinite(eig_tol);
    for (int e = 0; e < r * r; e++) {
        finite = finite && isfinite(D[e]); /* a NaN coefficient (mu) fails every comparison below */
    }
    if (!finite || verdict_real_parts(in, r, rows, D, size, j_scale, re, &slack) != 0) {
        return VERDICT_DECLINED;
    }
    int negative = 0, zero = 0;
    for (int a = 0; a < r; a++) {
        if (fabs(fabs(re[a]) - eig_tol) <= slack) {
            return VERDICT_DECLINED; /* on the tolerance's edge, to round-off */
        }
        negative |= re[a] < -eig_tol;
        zero |= fabs(re[a]) <= eig_tol;
    }
    return negative ? VERDICT_UNSTABLE : zero ? VERDICT_NONE : VERDICT_STABLE;
}

static const Arg verdict_table[] = {
    {"factor", 's', 2, {DIM_N, DIM_N}, 0},     {"jacobian_normal", 's', 2, {DIM_K, DIM_N}, 0},
    {"jacobian_tangent", 's', 2, {DIM_K, DIM_N}, 0}, {"mu", 's', 1, {DIM_K}, 0},
    {"normal_velocities", 's', 1, {DIM_K}, 0}, {"tangential_velocities", 's', 1, {DIM_K}, 0},
    {"mode", 'o', 0, {0}, 0},                  {"lambda_n", 's', 1, {DIM_K}, 0},
    {"lambda_t", 's', 1, {DIM_K}, 0},          {"a_n", 's', 1, {DIM_K}, 0},
    {"a_t", 's', 1, {DIM_K}, 0},               {"dv", 's', 1, {DIM_N}, 0},
    {"velocity_tolerance", 'f', 0, {0}, 0},    {"mass_scale", 'f', 0, {0}, 0},
    {"bias_scale", 'f', 0, {0}, 0},            {"force_tolerance", 'f', 0, {0}, 0},
    {"acceleration_tolerance", 'f', 0, {0}, 0}, {"eigenvalue_tolerance", 'f', 0, {0}, 0},
    {"rank_tolerance", 'f', 0, {0}, 0},        {"range_low", 'f', 0, {0}, 0},
    {"range_high", 'f', 0, {0}, 0},            {"band", 'f', 0, {0}, 0},
    {"rank_separation", 'f', 0, {0}, 0}};
static const Signature verdict_signature = {"held_verdict", 23, verdict_table, NULL};

static PyObject *held_verdict(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    if (parse(&verdict_signature, args, nargs, &a)) {
        goto done;
    }
    const double *f = a.number;
    VerdictInput in = {&a.buffer[0].view, &a.buffer[1].view, &a.buffer[2].view, &a.buffer[3].view,
                       &a.buffer[4].view, &a.buffer[5].view, &a.buffer[7].view, &a.buffer[8].view,
                       &a.buffer[9].view, &a.buffer[10].view, &a.buffer[11].view, a.dim[DIM_N], a.dim[DIM_K],
                       f[12], f[13], f[14], f[15], f[16], f[17], f[18], f[19], f[20], f[21], f[22]};
    PyObject *mode = args[6];
    Py_ssize_t length = 0;
    const char *letters = PyUnicode_Check(mode) ? PyUnicode_AsUTF8AndSize(mode, &length) : NULL;
    PyErr_Clear();
    int fits = letters != NULL && length == in.k; /* k bytes, each a mode letter: k letters */
    for (Py_ssize_t i = 0; fits && i < length; i++) {
        fits = strchr("SLRF", letters[i]) != NULL && letters[i] != '\0';
    }
    int verdict = fits ? verdict_of(&in, letters) : VERDICT_DECLINED;
    result = PyLong_FromLong(verdict);
done:
    release_args(&a);
    return result;
}

/* ------------------------------------------------------------------------------------------------
 * redundancy_rows and ray_exit: the steps of Clarkson's redundancy loop around its LP
 * (frcontrol.polytope._irredundant_rows, whose NumPy twins _redundancy_rows_numpy and
 * _ray_exit_numpy are the reference), on unit rows unit z <= offsets (m, d) and the rows' status
 * (int8: 0 unknown, 1 irredundant, -1 redundant).
 *
 * redundancy_rows: the LP of row i's test gathered into rows (at least m + 1, d) and rhs: the rows
 * j in order with status[j] == 1 (against_all false: the rows known irredundant) or with
 * status[j] != -1 and j != i (against_all true: every row not removed), then row i with right side
 * offsets[i] + 1 (the LP's bound). Returns the count of rows before row i: a copy, bit for bit.
 *
 * ray_exit: the ray from the interior point center through the LP's optimum x, with slack =
 * offsets - unit center: per row with speed unit_j (x - center) > 0 and status != -1 its exit
 * slack_j / speed_j; j the first row of the least exit. Returns j, or -1 when row j is known
 * irredundant already or a second exit lies within tie_relative * exit_j + tie_absolute of it (the
 * ray meets a lower-dimensional face; no row ahead at all counts so too). The speeds are summed
 * in index order (NumPy's matrix product may sum in another: round-off).
 */
static const Arg gather_table[] = {
    {"unit", 'd', 2, {DIM_ROWS, DIM_N}, 0}, {"offsets", 'd', 1, {DIM_ROWS}, 0},
    {"status", 'b', 1, {DIM_ROWS}, 0},      {"i", 'i', 0, {0}, 0},
    {"against_all", 't', 0, {0}, 0},        {"rows", 'd', 2, {DIM_S, DIM_N}, WRITE},
    {"rhs", 'd', 1, {DIM_S}, WRITE}};
static const Signature gather_signature = {"redundancy_rows", 7, gather_table, NULL};

static PyObject *redundancy_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    if (parse(&gather_signature, args, nargs, &a)) {
        goto done;
    }
    Py_ssize_t m = a.dim[DIM_ROWS], d = a.dim[DIM_N], i = (Py_ssize_t)a.integer[3];
    if (i < 0 || i >= m) {
        PyErr_Format(kernel_error, "kernel argument i: %zd is not a row of %zd", i, m);
        goto done;
    }
    if (a.dim[DIM_S] < m + 1) {
        PyErr_Format(kernel_error, "kernel buffer rows: %zd rows, expected at least m + 1 = %zd", a.dim[DIM_S],
                     m + 1);
        goto done;
    }
    const double *unit = a.data[0], *offsets = a.data[1];
    const signed char *status = a.data[2];
    int against_all = (int)a.integer[4];
    double *rows = a.data[5], *rhs = a.data[6];
    Py_ssize_t k = 0;
    for (Py_ssize_t j = 0; j < m; j++) {
        int taken = against_all ? (status[j] != -1 && j != i) : status[j] == 1;
        if (taken) {
            memcpy(rows + k * d, unit + j * d, (size_t)d * sizeof(double));
            rhs[k++] = offsets[j];
        }
    }
    memcpy(rows + k * d, unit + i * d, (size_t)d * sizeof(double));
    rhs[k] = offsets[i] + 1.0;
    result = PyLong_FromSsize_t(k);
done:
    release_args(&a);
    return result;
}

static const Arg ray_table[] = {
    {"unit", 'd', 2, {DIM_ROWS, DIM_N}, 0}, {"slack", 'd', 1, {DIM_ROWS}, 0},
    {"status", 'b', 1, {DIM_ROWS}, 0},      {"x", 'd', 1, {DIM_N}, 0},
    {"center", 'd', 1, {DIM_N}, 0},         {"tie_relative", 'f', 0, {0}, 0},
    {"tie_absolute", 'f', 0, {0}, 0}};
static const Signature ray_signature = {"ray_exit", 7, ray_table, NULL};

static PyObject *ray_exit(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    Args a;
    PyObject *result = NULL;
    if (parse(&ray_signature, args, nargs, &a)) {
        goto done;
    }
    Py_ssize_t m = a.dim[DIM_ROWS], d = a.dim[DIM_N], j = 0;
    const double *unit = a.data[0], *slack = a.data[1], *x = a.data[3], *center = a.data[4];
    const signed char *status = a.data[2];
    double best = HUGE_VAL, second = HUGE_VAL;
    for (Py_ssize_t r = 0; r < m; r++) {
        double speed = 0.0;
        for (Py_ssize_t c = 0; c < d; c++) {
            speed += unit[r * d + c] * (x[c] - center[c]);
        }
        double exit = speed > 0.0 && status[r] != -1 ? slack[r] / speed : HUGE_VAL;
        if (exit < best) {
            second = best;
            best = exit;
            j = r;
        } else if (exit < second) {
            second = exit;
        }
    }
    int face = m == 0 || status[j] == 1 || second <= best * (1.0 + a.number[5]) + a.number[6];
    result = PyLong_FromSsize_t(face ? -1 : j);
done:
    release_args(&a);
    return result;
}

#ifndef FRC_KERNEL_SOURCE_SHA256
#define FRC_KERNEL_SOURCE_SHA256 "" /* built without setup.py: the source it came from is not known */
#endif

static PyMethodDef methods[] = {
    {"certified_modes", (PyCFunction)(void (*)(void))certified_modes, METH_FASTCALL,
     "certified_modes(dynamics, equalities, equality_rhs, inequalities, inequality_rhs, valid, motion,\n"
     "                letters, input_map, bias, u, status, x, residual, violation, a_hat, r_scale,\n"
     "                c_scale, margin, tolerance, domain_tolerance, zero_row_tolerance) -> None\n\n"
     "Every mode of `letters` (count, k): certified or not, and, when certified, its x, whether its\n"
     "inequalities hold at u, its equality residual and inequality violation, written into status\n"
     "(int8: NOT_CERTIFIED, CERTIFIED_INADMISSIBLE, CERTIFIED_ADMISSIBLE), x (count, nx), residual\n"
     "and violation (count,); every mode's equilibrated A and scalings into a_hat (count, nx, nx),\n"
     "r_scale and c_scale (count, nx)."},
    {"rank_modes", (PyCFunction)(void (*)(void))rank_modes, METH_FASTCALL,
     "rank_modes(dynamics, ..., u, U, s, Vt, r_scale, c_scale, status, x, w, outputs, residual,\n"
     "           violation, rank_tolerance, band, domain_tolerance, zero_row_tolerance, radius_cap,\n"
     "           consistency_tolerance, output_tolerance) -> bool\n\n"
     "The modes of `letters` from their equilibrated A's SVD (U, s, Vt): True, deciding nothing, when a\n"
     "singular value lies in the ill-conditioned band; else each mode's status (int8: INADMISSIBLE,\n"
     "ADMISSIBLE, ADMISSIBLE_W with one ambiguity variable, NEEDS_PYTHON with more), x, w,\n"
     "outputs (MOVES_NONE, MOVES_FORCES, MOVES_ACCELERATIONS), residual and violation."},
    {"lp_check", (PyCFunction)(void (*)(void))lp_check, METH_FASTCALL,
     "lp_check(A_ub, b_ub, A_eq, b_eq, lb, ub, x, has_bounds) -> (residual, scale)\n\n"
     "The LP door's primal residual of x (NaN for x None) and the scale of its tolerance\n"
     "(frcontrol.solvers.primal_residual and FEASIBILITY_TOLERANCE), in one pass."},
    {"robot_state", (PyCFunction)(void (*)(void))robot_state, METH_FASTCALL,
     "robot_state(plan, q, v, frames, positions, lines, damping) -> state\n\n"
     "frcontrol.model.PlanarRobot.state after Pinocchio's computeAllTerms: a new instance of the state\n"
     "type (its fields in its __dict__) from Pinocchio's M (upper triangle) and nle and, per frame of\n"
     "the tuple frames, Pinocchio's position (read after updateFramePlacement from the frame's view in\n"
     "the tuple positions, data.oMf[frame].translation), world-aligned Jacobian and classical\n"
     "acceleration; lines (a tuple of 5 k floats) holds each contact's n, t and n . s, damping (or\n"
     "None) the drives' b. plan: (state type, numpy.empty, model, data, updateFramePlacement,\n"
     "getFrameJacobian, getFrameClassicalAcceleration, LOCAL_WORLD_ALIGNED, v_index (int64, or None:\n"
     "the identity), nv, data.M, data.nle), the last two views of the data's storage."},
    {"scratch_plan", (PyCFunction)(void (*)(void))scratch_plan, METH_FASTCALL,
     "scratch_plan(robot, frames, positions, lines, damping, input_map, mu, lower, upper, solution_type,\n"
     "             empty, names, float64, outputs, slack, velocity_tolerance, margin, tolerance,\n"
     "             domain_tolerance, zero_row_tolerance, max_modes, rank_tolerance, round_off_rank_drop,\n"
     "             void_factor, exact_factor, balancing_friction, output_tolerance, radius_cap) -> plan\n\n"
     "What scratch_solutions reads of a scene that does not change with its state: the robot_state plan\n"
     "and the contacts' frames, positions and lines (all four None: a problem's plan, for\n"
     "problem_solutions), the damping (or None), S^T (n, m), mu (k,), the input limits, the solution\n"
     "class, numpy.empty, the input names, numpy.float64, the ambiguous outputs' three names and the\n"
     "batch path's tolerances and constants (frcontrol.engine._plan_numbers)."},
    {"scratch_solutions", (PyCFunction)(void (*)(void))scratch_solutions, METH_FASTCALL,
     "scratch_solutions(plan, v, inputs) -> [solution, ...], None or False\n\n"
     "Every rigid solution at the plain input `inputs` from the state whose Pinocchio pass (computeAllTerms\n"
     "at q and v) has just run: the state, the letters by velocity, every full mode's certificate and\n"
     "decision, as robot_state, contact_rows and certified_modes do, and a rank-deficient mode with one\n"
     "ambiguity variable by its rows; None where the general path must answer (an input not plain, an\n"
     "impact, too many modes or contacts), False where it must because neither certificate takes a\n"
     "mode (the state decides that, not the input)."},
    {"problem_solutions", (PyCFunction)(void (*)(void))problem_solutions, METH_FASTCALL,
     "problem_solutions(plan, mass, jacobian_normal, jacobian_tangent, drift_normal, drift_tangent,\n"
     "                  normal_velocities, tangential_velocities, bias, inputs) -> [solution, ...], None\n"
     "                  or False\n\n"
     "scratch_solutions from a contact problem's arrays, on a scratch_plan made without a robot (robot,\n"
     "frames, positions and lines None)."},
    {"contact_rows", (PyCFunction)(void (*)(void))contact_rows, METH_FASTCALL,
     "contact_rows(mass, jacobian_normal, jacobian_tangent, drift_normal, drift_tangent, mu,\n"
     "             normal_velocities, tangential_velocities, velocity_tolerance, dynamics, equalities,\n"
     "             equality_rhs, inequalities, inequality_rhs, valid, motion) -> None\n\n"
     "frcontrol.modes.dynamics_rows and contact_row_table written into the given arrays (n, nx),\n"
     "(k, 4, 2, nx), (k, 4, 2), (k, 4, 3, nx), (k, 4, 3) and the bool (k, 4, 3) twice; bit for bit."},
    {"certified_children", (PyCFunction)(void (*)(void))certified_children, METH_FASTCALL,
     "certified_children(A, B, c, X_u, x_0, X_w, bound, limit) -> None\n\n"
     "frcontrol.response.certified_responses of systems A (count, rows, nx) sharing B (rows, m), with\n"
     "c (count, rows): each one's condition bound into bound (count,) (+inf when a pivot rules it\n"
     "out), and where bound < limit its X_u (count, nx, m), x_0 (count, nx), X_w (count, nx, nx - rows)."},
    {"certified_by_rows", (PyCFunction)(void (*)(void))certified_by_rows, METH_FASTCALL,
     "certified_by_rows(A, B, c, kept, X_u, x_0, X_w, info, limit) -> None\n\n"
     "frcontrol.response.certified_by_rows's factorisation: per system of A (count, rows, nx), with B\n"
     "(rows, m) shared and c (count, rows), its kept rows (int64, count x q) factorised under the\n"
     "whole system's scalings; the kept rows' minimum-norm X_u (count, nx, m), x_0 (count, nx), their\n"
     "null space X_w (count, nx, nx - q) and info (count, 7): bound, ||A_hat Q_2||_F, the residuals\n"
     "of B and c on every row, ||A_hat||_F, the consistency scale and the right side's norm."},
    {"margin_rows", (PyCFunction)(void (*)(void))margin_rows, METH_FASTCALL,
     "margin_rows(G, X_u, X_w, x_0, g, C, d, motion, out, h_out, zero_row_tolerance, domain_tolerance)\n"
     "-> int\n\n"
     "The motion LP's rows of a mode's domain (frcontrol.engine.domain_rows and motion_margin) written\n"
     "into out (rows, m + p + 1) and h_out (rows,): -1 when a constant motion row is violated, else\n"
     "1 (a constant motion row is not strict) + 2 (some motion row is moving)."},
    {"margin_lp", (PyCFunction)(void (*)(void))margin_lp, METH_FASTCALL,
     "margin_lp(rows, h, x, cap, domain_tolerance, band, residual, empty, pivot, optimality,\n"
     "          zero_row_tolerance) -> int\n\n"
     "The motion LP without equalities (max t over rows (R, d + 1) [z, t] <= h, 0 <= t <= cap) by a\n"
     "dense simplex on its dual, every answer checked: 1 (t* above domain_tolerance band, x written), 2\n"
     "(t* below domain_tolerance / band, x a point of the set), 3 (the set is empty), 0 (undecided:\n"
     "solve it elsewhere)."},
    {"locate_points", (PyCFunction)(void (*)(void))locate_points, METH_FASTCALL,
     "locate_points(H_u, h_0, norms, motion, H_w1, p, rows, inequality_rows, X_u, X_w, x_0, K,\n"
     "              domain_tolerance, zero_row_tolerance, radius_cap, U, status, w) -> None\n\n"
     "frcontrol.query.QueryTable.decide: per point of U (N, m) and mode, status (int8, N x modes:\n"
     "QUERY_OUTSIDE, QUERY_INSIDE, QUERY_NEEDS_PYTHON for a mode with two or more ambiguity variables\n"
     "whose consistency rows hold) and w (the interval rule's representative of a one-variable mode)."},
    {"evaluate_points", (PyCFunction)(void (*)(void))evaluate_points, METH_FASTCALL,
     "evaluate_points(<the table's 15 arguments>, U, point, index, w, x, acc, residual, violation) -> None\n\n"
     "frcontrol.query.QueryTable.evaluate: per solution (mode index[s] at U[point[s]], ambiguity w[s])\n"
     "x = X_u u + X_w w + x_0, and from y = K [x; u; 1] the contact accelerations, the largest equation\n"
     "residual and the largest inequality violation (at least 0)."},
    {"query_point", (PyCFunction)(void (*)(void))query_point, METH_FASTCALL,
     "query_point(<the table's 15 arguments>, u, status, w, x, acc, residual, violation) -> None\n\n"
     "locate_points for one input u (m,), and evaluate_points for every mode found inside, into its row\n"
     "of x (modes, nx), acc (modes, 2k), residual and violation (modes,)."},
    {"query_plan", (PyCFunction)(void (*)(void))query_plan, METH_FASTCALL,
     "query_plan(H_u, h_0, norms, motion, H_w1, p, rows, inequality_rows, X_u, X_w, x_0, K,\n"
     "           domain_tolerance, zero_row_tolerance, radius_cap, solution_type, modes, outputs, empty,\n"
     "           names, float64, lower, upper, slack, n, k) -> capsule\n\n"
     "The query table held for query_solutions."},
    {"query_solutions", (PyCFunction)(void (*)(void))query_solutions, METH_FASTCALL,
     "query_solutions(plan, inputs) -> list or None\n\n"
     "The single query on an analysis in one call: every solution at a plain input (m numbers, or a\n"
     "dict of numbers by input name), or None where the general path answers (not plain, not finite,\n"
     "outside the limits,\n"
     "or a mode with two or more ambiguity variables to decide)."},
    {"environment_value", (PyCFunction)environment_value, METH_O,
     "environment_value(name: bytes) -> str\n\nThe environment's value of name, \"\" when unset (getenv)."},
    {"lemke", (PyCFunction)(void (*)(void))lemke, METH_FASTCALL,
     "lemke(M, q, basis, matrix, rhs, max_pivots, pivot_tolerance, tie_tolerance) -> (status, pivots)\n\n"
     "frcontrol.lcp's lexicographic Lemke pivots on M (n, n) and q (n,): the final basis (int64, the\n"
     "tableau column basic in each row) into basis (n,), its columns of [I, -M, -1] into matrix\n"
     "(n, n) and the tableau's right side into rhs (n,), and the status\n"
     "(LEMKE_SOLVED, LEMKE_RAY, LEMKE_MAX_PIVOTS) with the number of pivots."},
    {"coulomb_matrix", (PyCFunction)(void (*)(void))coulomb_matrix, METH_FASTCALL,
     "coulomb_matrix(W, m_ref, mu, out) -> None\n\n"
     "frcontrol.simulation.impact's Coulomb impulse LCP matrix (4c, 4c) of the Delassus matrix W (2c, 2c)\n"
     "times m_ref and the friction coefficients mu (c,), written into out."},
    {"lcp_check", (PyCFunction)(void (*)(void))lcp_check_point, METH_FASTCALL,
     "lcp_check(M, q, z, w, tolerance, enumerated) -> (residual, bound, found)\n\n"
     "frcontrol.lcp._verified's check of a candidate z with w = M z + q: the natural-map residual,\n"
     "the largest row bound and whether every row is within its bound."},
    {"held_verdict", (PyCFunction)(void (*)(void))held_verdict, METH_FASTCALL,
     "held_verdict(factor, jacobian_normal, jacobian_tangent, mu, normal_velocities, tangential_velocities,\n"
     "             mode, lambda_n, lambda_t, a_n, a_t, dv, velocity_tolerance, mass_scale, bias_scale,\n"
     "             force_tolerance, acceleration_tolerance, eigenvalue_tolerance, rank_tolerance,\n"
     "             range_low, range_high, band, rank_separation) -> int\n\n"
     "frcontrol.stability.stable_verdicts' verdict on one solution where M has the Cholesky factor `factor`\n"
     "(upper): VERDICT_STABLE, VERDICT_UNSTABLE, VERDICT_NONE (not analysable) or VERDICT_DECLINED (the\n"
     "reference decides: more than two held rows, a rank or an eigenvalue's sign within round-off of\n"
     "its tolerance, a number not finite)."},
    {"compliant_law", (PyCFunction)(void (*)(void))compliant_law, METH_FASTCALL,
     "compliant_law(gaps, v_N, v_T, stretch, mu, k_N, b_N, k_T, b_T, lam_n, lam_t, rate, status) -> None\n\n"
     "frcontrol.simulation.compliant.contact_forces without contact zones: lam_N, lam_T, the stretch\n"
     "rates and the status (int64: 0 open, 1 stick, 2 slip) written into the last four arrays (c,)."},
    {"redundancy_rows", (PyCFunction)(void (*)(void))redundancy_rows, METH_FASTCALL,
     "redundancy_rows(unit, offsets, status, i, against_all, rows, rhs) -> k\n\n"
     "frcontrol.polytope's redundancy LP of row i gathered into rows and rhs: the rows with status 1\n"
     "(against_all: every row not removed, status != -1, but i), then row i with offsets[i] + 1;\n"
     "returns the count before row i."},
    {"ray_exit", (PyCFunction)(void (*)(void))ray_exit, METH_FASTCALL,
     "ray_exit(unit, slack, status, x, center, tie_relative, tie_absolute) -> j\n\n"
     "The first row the ray from center through x crosses (least slack / speed over the rows ahead not\n"
     "removed), or -1 when it is known irredundant or a second row is met there (to the tie tolerances)."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "frcontrol._kernel",
                                    "The compiled kernel of frcontrol.mode_batch.", -1,
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
    if (PyModule_AddStringConstant(mod, "SOURCE_SHA256", FRC_KERNEL_SOURCE_SHA256) != 0) {
        Py_DECREF(mod);
        return NULL;
    }
    enum { CONSTANTS = 20 };
    const char *names[CONSTANTS] = {
        "NOT_CERTIFIED", "CERTIFIED_INADMISSIBLE", "CERTIFIED_ADMISSIBLE", "INADMISSIBLE", "ADMISSIBLE",
        "NEEDS_PYTHON", "ADMISSIBLE_W", "MOVES_NONE", "MOVES_FORCES", "MOVES_ACCELERATIONS", "QUERY_OUTSIDE",
        "QUERY_INSIDE", "QUERY_NEEDS_PYTHON", "LEMKE_SOLVED", "LEMKE_RAY", "LEMKE_MAX_PIVOTS", "VERDICT_UNSTABLE",
        "VERDICT_STABLE", "VERDICT_NONE", "VERDICT_DECLINED"};
    int values[CONSTANTS] = {NOT_CERTIFIED, CERTIFIED_INADMISSIBLE, CERTIFIED_ADMISSIBLE, INADMISSIBLE, ADMISSIBLE,
                             NEEDS_PYTHON, ADMISSIBLE_W, MOVES_NONE, MOVES_FORCES, MOVES_ACCELERATIONS,
                             QUERY_OUTSIDE, QUERY_INSIDE, QUERY_NEEDS_PYTHON, LEMKE_SOLVED, LEMKE_RAY,
                             LEMKE_MAX_PIVOTS, VERDICT_UNSTABLE, VERDICT_STABLE, VERDICT_NONE, VERDICT_DECLINED};
    PyObject *all = PyList_New(0); /* every function of the method table, then every constant */
    if (all == NULL) {
        Py_DECREF(mod);
        return NULL;
    }
    Py_ssize_t functions = (Py_ssize_t)(sizeof(methods) / sizeof(methods[0])) - 1;
    for (Py_ssize_t i = 0; i < functions + CONSTANTS; i++) {
        const char *entry = i < functions ? methods[i].ml_name : names[i - functions];
        PyObject *name = PyUnicode_FromString(entry);
        int failed = name == NULL || PyList_Append(all, name) != 0 ||
                     (i >= functions && PyModule_AddIntConstant(mod, entry, values[i - functions]) != 0);
        Py_XDECREF(name);
        if (failed) {
            Py_DECREF(all);
            Py_DECREF(mod);
            return NULL;
        }
    }
    if (PyModule_AddObject(mod, "__all__", all) != 0) { /* steals the reference on success */
        Py_DECREF(all);
        Py_DECREF(mod);
        return NULL;
    }
    return mod;
}
