/* The compiled kernel of frcontrol.mode_batch (the certified-modes path of decide_modes), of
 * frcontrol.query (locate_points, evaluate_points: queries on an analysis) and of frcontrol.lcp
 * and frcontrol.simulation (lemke: the pivots of Lemke's method; lcp_check: the check of its
 * answer; coulomb_matrix: the LCP of the rigid simulation's step; compliant_law: the compliant
 * contact law).
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
    double *a_hat_out, *r_out, *c_out; /* certified_modes: every mode's A_hat and scalings */
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
        memcpy(p->a_hat_out + mode * nx * nx, s->A_hat, (size_t)(nx * nx) * sizeof(double));
        memcpy(p->r_out + mode * nx, s->r_scale, (size_t)nx * sizeof(double));
        memcpy(p->c_out + mode * nx, s->c_scale, (size_t)nx * sizeof(double));
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

/* outputs_moved_by for one direction X_w (nx,). */
static signed char moved_by(const Problem *p, const Ranked *q, const double *X_w) {
    double top = 0.0;
    for (Py_ssize_t i = 0; i < p->nx; i++) {
        top = fabs(X_w[i]) > top ? fabs(X_w[i]) : top;
    }
    double threshold = q->output_tolerance * (top > 1e-300 ? top : 1e-300);
    int moves_dv = 0, moves_forces = 0;
    for (Py_ssize_t i = 0; i < p->nx; i++) {
        if (fabs(X_w[i]) > threshold) {
            *(i < p->n ? &moves_dv : &moves_forces) = 1;
        }
    }
    return moves_dv ? MOVES_ACCELERATIONS : moves_forces ? MOVES_FORCES : MOVES_NONE;
}

/* The inequality rows at u as a_i w <= h_i (rows normalised in (u, w)); p = 0 decides them here.
 * Writes the valid rows' a, h, motion; returns their count, or -1 when p = 0 and a row fails. */
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
                double sq = 0.0, hu = 0.0, gx0 = 0.0, hw = 0.0;
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
                    hw += g[i] * X_w[i];
                }
                double norm = sqrt(sq + (pdim ? hw * hw : 0.0));
                if (pass == 0) {
                    largest = norm > largest ? norm : largest;
                    continue;
                }
                int constant = norm <= floor;
                norm = constant ? 1.0 : norm;
                a[rows] = constant ? 0.0 : hw / norm;
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

/* x = X_u u + X_w w + x_0, its equality residual and inequality violation. */
static void finish(const Problem *p, const long long *letters, const Scratch *s, const double *X_u,
                   const double *x0, const double *X_w, double w, double *x, double *residual,
                   double *violation) {
    Py_ssize_t nx = p->nx, m = p->m;
    for (Py_ssize_t i = 0; i < nx; i++) {
        double v = 0.0;
        for (Py_ssize_t c = 0; c < m; c++) {
            v += X_u[i * m + c] * p->u[c];
        }
        x[i] = v + X_w[i] * w + x0[i];
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
    q->outputs[mode] = pdim ? moved_by(p, q, X_w) : MOVES_NONE;
    finish(p, letters, s, X_u, x0, X_w, w, p->x + mode * nx, &p->residual[mode], &p->violation[mode]);
    return pdim ? ADMISSIBLE_W : ADMISSIBLE;
}

/* ------------------------------------------------------------------ arguments */

#define PROBLEM_BUFFERS 11
#define MAX_BUFFERS 22
static const char *problem_names[PROBLEM_BUFFERS] = {
    "dynamics", "equalities", "equality_rhs", "inequalities", "inequality_rhs", "valid", "motion",
    "letters", "input_map", "bias", "u"};

/* The problem's 11 buffers, reading n, nx, k, m and the mode count from them. */
static int take_problem(PyObject *const *args, Buffer *b, Problem *p) {
    Py_ssize_t s_dyn[2] = {-1, -1};
    if (take(args[0], &b[0], problem_names[0], 'd', 2, s_dyn, 0)) return -1;
    Py_ssize_t n = s_dyn[0], nx = s_dyn[1];
    Py_ssize_t s_eq[4] = {-1, LETTERS, EQUALITY_ROWS, nx};
    if (take(args[1], &b[1], problem_names[1], 'd', 4, s_eq, 0)) return -1;
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
    if (take(args[2], &b[2], problem_names[2], 'd', 3, s_eqr, 0) ||
        take(args[3], &b[3], problem_names[3], 'd', 4, s_in, 0) ||
        take(args[4], &b[4], problem_names[4], 'd', 3, s_inr, 0) ||
        take(args[5], &b[5], problem_names[5], '?', 3, s_valid, 0) ||
        take(args[6], &b[6], problem_names[6], '?', 3, s_motion, 0) ||
        take(args[7], &b[7], problem_names[7], 'q', 2, s_letters, 0) ||
        take(args[8], &b[8], problem_names[8], 'd', 2, s_map, 0)) {
        return -1;
    }
    Py_ssize_t count = s_letters[0], m = s_map[1];
    Py_ssize_t s_bias[1] = {n}, s_u[1] = {m};
    if (take(args[9], &b[9], problem_names[9], 'd', 1, s_bias, 0) ||
        take(args[10], &b[10], problem_names[10], 'd', 1, s_u, 0)) {
        return -1;
    }
    memset(p, 0, sizeof(*p));
    p->n = n, p->k = k, p->m = m, p->nx = nx, p->count = count;
    p->dynamics = b[0].view.buf, p->eq = b[1].view.buf, p->eq_rhs = b[2].view.buf;
    p->ineq = b[3].view.buf, p->ineq_rhs = b[4].view.buf;
    p->valid = b[5].view.buf, p->motion = b[6].view.buf, p->letters = b[7].view.buf;
    p->input_map = b[8].view.buf, p->bias = b[9].view.buf, p->u = b[10].view.buf;
    for (Py_ssize_t i = 0; i < count * k; i++) {
        if (p->letters[i] < 0 || p->letters[i] >= LETTERS) {
            PyErr_Format(kernel_error, "kernel buffer letters: entry %lld is not a letter index 0-3",
                         p->letters[i]);
            return -1;
        }
    }
    return 0;
}

/* Per-mode buffers after the problem's: names, kinds ('d' or 'b'), trailing shape (0: none,
 * 1: (nx,), 2: (nx, nx)), writable. */
typedef struct {
    const char *name;
    char kind;
    int tail;
    int writable;
} ModeBuffer;

static int take_modes(PyObject *const *args, Buffer *b, const Problem *p, const ModeBuffer *spec, int count,
                      void **out) {
    for (int i = 0; i < count; i++) {
        Py_ssize_t shape[3] = {p->count, p->nx, p->nx};
        if (take(args[PROBLEM_BUFFERS + i], &b[PROBLEM_BUFFERS + i], spec[i].name, spec[i].kind,
                 1 + spec[i].tail, shape, spec[i].writable)) {
            return -1;
        }
        out[i] = b[PROBLEM_BUFFERS + i].view.buf;
    }
    return 0;
}

static int take_floats(PyObject *const *args, Py_ssize_t first, const char *const *names, double **dest,
                       int count) {
    for (int i = 0; i < count; i++) {
        double v = PyFloat_AsDouble(args[first + i]);
        if (v == -1.0 && PyErr_Occurred()) {
            PyErr_Clear();
            PyErr_Format(kernel_error, "kernel argument %s: not a number", names[i]);
            return -1;
        }
        *dest[i] = v;
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

static const ModeBuffer certified_buffers[7] = {
    {"status", 'b', 0, 1}, {"x", 'd', 1, 1}, {"residual", 'd', 0, 1}, {"violation", 'd', 0, 1},
    {"a_hat", 'd', 2, 1}, {"r_scale", 'd', 1, 1}, {"c_scale", 'd', 1, 1}};
static const char *certified_floats[4] = {"margin", "tolerance", "domain_tolerance", "zero_row_tolerance"};

static PyObject *certified_modes(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != PROBLEM_BUFFERS + 7 + 4) {
        PyErr_Format(kernel_error, "certified_modes takes %d arguments, got %zd", PROBLEM_BUFFERS + 11, nargs);
        return NULL;
    }
    Buffer b[MAX_BUFFERS];
    memset(b, 0, sizeof(b));
    Problem p;
    PyObject *result = NULL;
    double *memory = NULL, *Su, *work;
    void *out[7];
    if (take_problem(args, b, &p) || take_modes(args, b, &p, certified_buffers, 7, out)) {
        goto done;
    }
    double *floats[4] = {&p.margin, &p.tolerance, &p.domain_tolerance, &p.zero_row_tolerance};
    if (take_floats(args, PROBLEM_BUFFERS + 7, certified_floats, floats, 4)) {
        goto done;
    }
    p.status = out[0], p.x = out[1], p.residual = out[2], p.violation = out[3];
    p.a_hat_out = out[4], p.r_out = out[5], p.c_out = out[6];
    Scratch s;
    memory = scratch(&p, &s, &Su, &work);
    if (memory == NULL) {
        goto done;
    }
    run_modes(&p, Su, &s);
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(memory);
    release(b, MAX_BUFFERS);
    return result;
}

static const ModeBuffer rank_buffers[11] = {
    {"U", 'd', 2, 0}, {"s", 'd', 1, 0}, {"Vt", 'd', 2, 0}, {"r_scale", 'd', 1, 0}, {"c_scale", 'd', 1, 0},
    {"status", 'b', 0, 1}, {"x", 'd', 1, 1}, {"w", 'd', 0, 1}, {"outputs", 'b', 0, 1},
    {"residual", 'd', 0, 1}, {"violation", 'd', 0, 1}};
static const char *rank_floats[7] = {"rank_tolerance", "band", "domain_tolerance", "zero_row_tolerance",
                                     "radius_cap", "consistency_tolerance", "output_tolerance"};

static PyObject *rank_modes(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != PROBLEM_BUFFERS + 11 + 7) {
        PyErr_Format(kernel_error, "rank_modes takes %d arguments, got %zd", PROBLEM_BUFFERS + 18, nargs);
        return NULL;
    }
    Buffer b[MAX_BUFFERS];
    memset(b, 0, sizeof(b));
    Problem p;
    Ranked q;
    PyObject *result = NULL;
    double *memory = NULL, *Su, *work;
    void *io[11];
    if (take_problem(args, b, &p) || take_modes(args, b, &p, rank_buffers, 11, io)) {
        goto done;
    }
    double *floats[7] = {&q.rank_tolerance, &q.band, &p.domain_tolerance, &p.zero_row_tolerance,
                         &q.radius_cap, &q.consistency_tolerance, &q.output_tolerance};
    if (take_floats(args, PROBLEM_BUFFERS + 11, rank_floats, floats, 7)) {
        goto done;
    }
    q.U = io[0], q.s = io[1], q.Vt = io[2], q.r_in = io[3], q.c_in = io[4];
    p.status = io[5], p.x = io[6], q.w = io[7], q.outputs = io[8], p.residual = io[9], p.violation = io[10];
    Py_ssize_t nx = p.nx;
    for (Py_ssize_t mode = 0; mode < p.count; mode++) { /* the band first: then nothing is decided */
        const double *sv = q.s + mode * nx;
        for (Py_ssize_t i = 0; i < nx; i++) {
            if (sv[i] > q.rank_tolerance * sv[0] && sv[i] <= q.band * sv[0]) {
                result = Py_NewRef(Py_True);
                goto done;
            }
        }
    }
    Scratch s;
    memory = scratch(&p, &s, &Su, &work);
    if (memory == NULL) {
        goto done;
    }
    for (Py_ssize_t mode = 0; mode < p.count; mode++) {
        memset(p.x + mode * nx, 0, (size_t)nx * sizeof(double));
        q.w[mode] = p.residual[mode] = p.violation[mode] = 0.0;
        q.outputs[mode] = MOVES_NONE;
        p.status[mode] = rank_mode(&p, &q, mode, Su, &s, work);
    }
    result = Py_NewRef(Py_False);
done:
    PyMem_Free(memory);
    release(b, MAX_BUFFERS);
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

static PyObject *lp_check(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 8) {
        PyErr_Format(kernel_error, "lp_check takes 8 arguments, got %zd", nargs);
        return NULL;
    }
    Buffer b[7];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    Py_ssize_t ub_shape[2] = {-1, -1}, n = 0, m_ub, m_eq;
    if (take(args[0], &b[0], "A_ub", 'd', 2, ub_shape, 0)) {
        goto done;
    }
    n = ub_shape[1], m_ub = ub_shape[0];
    Py_ssize_t b_ub_shape[1] = {m_ub}, eq_shape[2] = {-1, n}, vector[1] = {n}, x_shape[1] = {0};
    if (take(args[1], &b[1], "b_ub", 'd', 1, b_ub_shape, 0) || take(args[2], &b[2], "A_eq", 'd', 2, eq_shape, 0)) {
        goto done;
    }
    m_eq = eq_shape[0];
    Py_ssize_t b_eq_shape[1] = {m_eq};
    if (take(args[3], &b[3], "b_eq", 'd', 1, b_eq_shape, 0) || take(args[4], &b[4], "lb", 'd', 1, vector, 0) ||
        take(args[5], &b[5], "ub", 'd', 1, vector, 0)) {
        goto done;
    }
    int has_x = args[6] != Py_None;
    x_shape[0] = n;
    if (has_x && take(args[6], &b[6], "x", 'd', 1, x_shape, 0)) {
        goto done;
    }
    int has_bounds = PyObject_IsTrue(args[7]);
    if (has_bounds < 0) {
        goto done;
    }
    const double *A_ub = b[0].view.buf, *b_ub = b[1].view.buf, *A_eq = b[2].view.buf, *b_eq = b[3].view.buf;
    const double *lb = b[4].view.buf, *ub = b[5].view.buf, *x = has_x ? b[6].view.buf : NULL;
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
    release(b, 7);
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

/* A float64 buffer of ndim dimensions with any strides; shape entries >= 0 must match. */
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
    for (int i = 0; i < ndim; i++) {
        if (shape[i] >= 0 && b->view.shape[i] != shape[i]) {
            PyErr_Format(kernel_error, "kernel buffer %s: axis %d has %zd entries, expected %zd", name, i,
                         b->view.shape[i], shape[i]);
            return -1;
        }
        shape[i] = b->view.shape[i];
    }
    return 0;
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
    for (int i = 0; i < ndim; i++) {
        if (shape[i] >= 0 && b->view.shape[i] != shape[i]) {
            PyErr_Format(kernel_error, "kernel buffer %s: axis %d has %zd entries, expected %zd", name, i,
                         b->view.shape[i], shape[i]);
            return -1;
        }
    }
    return 0;
}

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

/* Checks the plan (with its mass and nle), v, frames, positions, lines and damping into b and job. */
static int take_state_inputs(PyObject *const *args, Buffer *b, StateJob *job) {
    PyObject *plan = args[A_PLAN];
    if (!PyTuple_Check(plan) || PyTuple_GET_SIZE(plan) != PLAN_ENTRIES || !PyType_Check(PyTuple_GET_ITEM(plan, P_TYPE)) ||
        !PyTuple_Check(args[A_FRAMES]) || !PyTuple_Check(args[A_POSITIONS]) ||
        PyTuple_GET_SIZE(args[A_POSITIONS]) != PyTuple_GET_SIZE(args[A_FRAMES])) {
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
    Py_ssize_t nv = job->nv, vec[1] = {-1}, mass_shape[2] = {nv, nv}, nle_shape[1] = {nv};
    job->k = PyTuple_GET_SIZE(args[A_FRAMES]);
    if (!PyTuple_Check(args[A_LINES]) || PyTuple_GET_SIZE(args[A_LINES]) != LINE_ENTRIES * job->k) {
        PyErr_Format(kernel_error, "robot_state: lines must be a tuple of %zd floats", LINE_ENTRIES * job->k);
        return -1;
    }
    job->lines = PyMem_Malloc((size_t)(LINE_ENTRIES * job->k + 1) * sizeof(double));
    if (job->lines == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    for (Py_ssize_t i = 0; i < LINE_ENTRIES * job->k; i++) {
        job->lines[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(args[A_LINES], i));
        if (job->lines[i] == -1.0 && PyErr_Occurred()) {
            PyErr_Clear();
            PyErr_Format(kernel_error, "robot_state: lines[%zd] is not a number", i);
            return -1;
        }
    }
    if (take_strided(args[A_V], &b[0], "v", 1, vec) || take_pinocchio(job->plan[P_MASS], &b[1], "mass", 2, mass_shape) ||
        take_pinocchio(job->plan[P_NLE], &b[2], "nle", 1, nle_shape)) {
        return -1;
    }
    job->n = vec[0], job->v = &b[0].view;
    Py_ssize_t n_shape[1] = {job->n};
    if (job->plan[P_V_INDEX] == Py_None) {
        if (job->n != nv) {
            PyErr_Format(kernel_error, "robot_state: v has %zd entries, expected %zd", job->n, nv);
            return -1;
        }
    } else {
        if (take(job->plan[P_V_INDEX], &b[4], "v_index", 'q', 1, n_shape, 0)) {
            return -1;
        }
        job->v_index = b[4].view.buf;
        for (Py_ssize_t a = 0; a < job->n; a++) {
            if (job->v_index[a] < 0 || job->v_index[a] >= nv) {
                PyErr_Format(kernel_error, "robot_state: v_index[%zd] = %lld is outside 0..%zd", a,
                             job->v_index[a], nv - 1);
                return -1;
            }
        }
    }
    if (args[A_DAMPING] != Py_None) {
        if (take(args[A_DAMPING], &b[5], "damping", 'd', 1, n_shape, 0)) {
            return -1;
        }
        job->damping = b[5].view.buf;
    }
    return 0;
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
    if (nargs != STATE_ARGS) {
        PyErr_Format(kernel_error, "robot_state takes %d arguments, got %zd", STATE_ARGS, nargs);
        return NULL;
    }
    if (intern_names()) {
        return NULL;
    }
    Buffer b[6], out[3]; /* inputs: v, mass, nle, (unused), v_index, damping; the three new arrays */
    memset(b, 0, sizeof(b));
    memset(out, 0, sizeof(out));
    StateJob job;
    memset(&job, 0, sizeof(job));
    PyObject *values[STATE_FIELDS] = {NULL}, *result = NULL;
    if (take_state_inputs(args, b, &job) == 0 && state_arrays(&job, job.plan[P_EMPTY], values, out) == 0) {
        fill_dynamics(&job, &b[1].view, &b[2].view);
        if (fill_contacts(&job, args[A_FRAMES], args[A_POSITIONS]) == 0) {
            values[0] = args[A_Q];
            values[1] = args[A_V];
            result = new_state(job.plan[P_TYPE], values);
        }
    }
    PyMem_Free(job.lines);
    release(b, 6);
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

#define ROW_INPUTS 8  /* mass, jn, jt, dn, dt, mu, vn, vt */
#define ROW_OUTPUTS 7 /* dynamics, eq, eq_rhs, ineq, ineq_rhs, valid, motion */

static int take_row_buffers(PyObject *const *args, Buffer *b, RowJob *r) {
    const char *names[ROW_INPUTS] = {"mass", "jacobian_normal", "jacobian_tangent", "drift_normal",
                                     "drift_tangent", "mu", "normal_velocities", "tangential_velocities"};
    Py_ssize_t mass[2] = {-1, -1};
    if (take_strided(args[0], &b[0], names[0], 2, mass)) {
        return -1;
    }
    Py_ssize_t n = mass[0], jn[2] = {-1, n};
    if (mass[1] != n) {
        PyErr_Format(kernel_error, "kernel buffer mass: %zd x %zd, expected a square matrix", n, mass[1]);
        return -1;
    }
    if (take_strided(args[1], &b[1], names[1], 2, jn)) {
        return -1;
    }
    Py_ssize_t k = jn[0], nx = n + 2 * k, jt[2] = {k, n};
    if (take_strided(args[2], &b[2], names[2], 2, jt)) {
        return -1;
    }
    for (int j = 3; j < ROW_INPUTS; j++) {
        Py_ssize_t vector[1] = {k};
        if (take_strided(args[j], &b[j], names[j], 1, vector)) {
            return -1;
        }
    }
    r->tolerance = PyFloat_AsDouble(args[ROW_INPUTS]);
    if (r->tolerance == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        PyErr_SetString(kernel_error, "contact_rows: velocity_tolerance is not a number");
        return -1;
    }
    Py_ssize_t dyn[2] = {n, nx}, eq[4] = {k, ROW_LETTERS, EQUALITY_ROWS, nx}, eq_rhs[3] = {k, ROW_LETTERS, EQUALITY_ROWS};
    Py_ssize_t in[4] = {k, ROW_LETTERS, INEQUALITY_ROWS, nx}, in_rhs[3] = {k, ROW_LETTERS, INEQUALITY_ROWS};
    Py_ssize_t flags[3] = {k, ROW_LETTERS, INEQUALITY_ROWS}, flags2[3] = {k, ROW_LETTERS, INEQUALITY_ROWS};
    PyObject *const *out = args + ROW_INPUTS + 1;
    Buffer *ob = b + ROW_INPUTS;
    if (take(out[0], &ob[0], "dynamics", 'd', 2, dyn, 1) || take(out[1], &ob[1], "equalities", 'd', 4, eq, 1) ||
        take(out[2], &ob[2], "equality_rhs", 'd', 3, eq_rhs, 1) ||
        take(out[3], &ob[3], "inequalities", 'd', 4, in, 1) ||
        take(out[4], &ob[4], "inequality_rhs", 'd', 3, in_rhs, 1) ||
        take(out[5], &ob[5], "valid", '?', 3, flags, 1) || take(out[6], &ob[6], "motion", '?', 3, flags2, 1)) {
        return -1;
    }
    *r = (RowJob){n, k, nx, &b[0].view, &b[1].view, &b[2].view, &b[3].view, &b[4].view, &b[5].view,
                  &b[6].view, &b[7].view, r->tolerance, ob[0].view.buf, ob[1].view.buf, ob[2].view.buf,
                  ob[3].view.buf, ob[4].view.buf, ob[5].view.buf, ob[6].view.buf};
    return 0;
}

static PyObject *contact_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != ROW_INPUTS + 1 + ROW_OUTPUTS) {
        PyErr_Format(kernel_error, "contact_rows takes %d arguments, got %zd", ROW_INPUTS + 1 + ROW_OUTPUTS, nargs);
        return NULL;
    }
    Buffer b[ROW_INPUTS + ROW_OUTPUTS];
    memset(b, 0, sizeof(b));
    RowJob r;
    memset(&r, 0, sizeof(r));
    PyObject *result = NULL;
    if (take_row_buffers(args, b, &r) == 0) {
        Py_ssize_t n = r.n, k = r.k, nx = r.nx;
        for (Py_ssize_t a = 0; a < n; a++) { /* [M, -J_N^T, -J_T^T] */
            for (Py_ssize_t c = 0; c < n; c++) {
                r.dynamics[a * nx + c] = at2(r.mass, a, c);
            }
            for (Py_ssize_t i = 0; i < k; i++) {
                r.dynamics[a * nx + n + i] = -at2(r.jn, i, a);
                r.dynamics[a * nx + n + k + i] = -at2(r.jt, i, a);
            }
        }
        memset(r.eq, 0, (size_t)(k * ROW_LETTERS * EQUALITY_ROWS * nx) * sizeof(double));
        memset(r.eq_rhs, 0, (size_t)(k * ROW_LETTERS * EQUALITY_ROWS) * sizeof(double));
        memset(r.ineq, 0, (size_t)(k * ROW_LETTERS * INEQUALITY_ROWS * nx) * sizeof(double));
        memset(r.ineq_rhs, 0, (size_t)(k * ROW_LETTERS * INEQUALITY_ROWS) * sizeof(double));
        memset(r.valid, 0, (size_t)(k * ROW_LETTERS * INEQUALITY_ROWS));
        memset(r.motion, 0, (size_t)(k * ROW_LETTERS * INEQUALITY_ROWS));
        for (Py_ssize_t i = 0; i < k; i++) {
            contact_rows_of(&r, i);
        }
        result = Py_NewRef(Py_None);
    }
    release(b, ROW_INPUTS + ROW_OUTPUTS);
    return result;
}

/* The motion LP's rows of a mode (frcontrol.engine.domain_rows, then motion_margin's rows): with
 * H = [G X_u, G X_w; C, 0] and h = [g - G x_0; d], out = [H, t] where t is each moving row's norm
 * ||H_i|| (0 elsewhere) and h_out = h. motion (one flag per row of G) marks the motion rows; the
 * input limits' rows C u <= d never are. A row is constant when its norm is at most
 * zero_row_tolerance * max(1, the largest norm); a motion row is moving unless constant. Returns -1
 * when a constant motion row has h_i < -domain_tolerance (the set is empty), else
 * 1 (a constant motion row has h_i <= domain_tolerance) + 2 (some row is moving). */
static PyObject *margin_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 12) {
        PyErr_Format(kernel_error, "margin_rows takes 12 arguments, got %zd", nargs);
        return NULL;
    }
    Buffer b[10];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    double *norms = NULL;
    Py_ssize_t g_shape[2] = {-1, -1}, u_shape[2] = {-1, -1}, w_shape[2] = {-1, -1};
    if (take(args[0], &b[0], "G", 'd', 2, g_shape, 0)) goto done;
    Py_ssize_t r = g_shape[0], nx = g_shape[1];
    u_shape[0] = w_shape[0] = nx;
    if (take(args[1], &b[1], "X_u", 'd', 2, u_shape, 0) || take(args[2], &b[2], "X_w", 'd', 2, w_shape, 0)) goto done;
    Py_ssize_t m = u_shape[1], p = w_shape[1];
    Py_ssize_t x0_shape[1] = {nx}, gv_shape[1] = {r}, c_shape[2] = {-1, m};
    if (take(args[3], &b[3], "x_0", 'd', 1, x0_shape, 0) || take(args[4], &b[4], "g", 'd', 1, gv_shape, 0) ||
        take(args[5], &b[5], "C", 'd', 2, c_shape, 0)) goto done;
    Py_ssize_t rows = r + c_shape[0], d = m + p;
    Py_ssize_t d_shape[1] = {c_shape[0]}, motion_shape[1] = {r}, out_shape[2] = {rows, d + 1}, h_shape[1] = {rows};
    if (take(args[6], &b[6], "d", 'd', 1, d_shape, 0) || take(args[7], &b[7], "motion", '?', 1, motion_shape, 0) ||
        take(args[8], &b[8], "out", 'd', 2, out_shape, 1) || take(args[9], &b[9], "h_out", 'd', 1, h_shape, 1)) goto done;
    double zero_row_tolerance = 0.0, domain_tolerance = 0.0;
    double *floats[2] = {&zero_row_tolerance, &domain_tolerance};
    static const char *float_names[2] = {"zero_row_tolerance", "domain_tolerance"};
    if (take_floats(args, 10, float_names, floats, 2)) goto done;
    const double *G = b[0].view.buf, *X_u = b[1].view.buf, *X_w = b[2].view.buf, *x_0 = b[3].view.buf;
    const double *g = b[4].view.buf, *C = b[5].view.buf, *dv = b[6].view.buf;
    const unsigned char *motion = b[7].view.buf;
    double *out = b[8].view.buf, *h = b[9].view.buf;
    norms = PyMem_Malloc((size_t)(rows + 1) * sizeof(double));
    if (norms == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double largest = 0.0;
    for (Py_ssize_t i = 0; i < rows; i++) {
        double *row = out + i * (d + 1);
        if (i < r) {
            const double *Gi = G + i * nx;
            double v = g[i];
            for (Py_ssize_t j = 0; j < d; j++) {
                row[j] = 0.0;
            }
            for (Py_ssize_t k = 0; k < nx; k++) {
                double a = Gi[k];
                if (a == 0.0) {
                    continue;
                }
                for (Py_ssize_t j = 0; j < m; j++) {
                    row[j] += a * X_u[k * m + j];
                }
                for (Py_ssize_t j = 0; j < p; j++) {
                    row[m + j] += a * X_w[k * p + j];
                }
                v -= a * x_0[k];
            }
            h[i] = v;
        } else {
            for (Py_ssize_t j = 0; j < m; j++) {
                row[j] = C[(i - r) * m + j];
            }
            for (Py_ssize_t j = m; j < d; j++) {
                row[j] = 0.0;
            }
            h[i] = dv[i - r];
        }
        double sum = 0.0;
        for (Py_ssize_t j = 0; j < d; j++) {
            sum += row[j] * row[j];
        }
        norms[i] = sqrt(sum);
        largest = norms[i] > largest ? norms[i] : largest;
    }
    double floor = zero_row_tolerance * (largest > 1.0 ? largest : 1.0);
    long flags = 0;
    for (Py_ssize_t i = 0; i < rows; i++) {
        int constant = norms[i] <= floor, moves = i < r && motion[i];
        out[i * (d + 1) + d] = moves && !constant ? norms[i] : 0.0;
        if (moves && constant) {
            if (h[i] < -domain_tolerance) {
                result = PyLong_FromLong(-1);
                goto done;
            }
            if (h[i] <= domain_tolerance) {
                flags |= 1;
            }
        } else if (moves) {
            flags |= 2;
        }
    }
    result = PyLong_FromLong(flags);
done:
    PyMem_Free(norms);
    release(b, 10);
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
} QRScratch;

static void householder(QRScratch *w) {
    Py_ssize_t rows = w->rows, nx = w->nx;
    double *M = w->M; /* M[i * rows + j] = A_hat[j][i] */
    for (Py_ssize_t j = 0; j < rows; j++) {
        double alpha = M[j * rows + j], xnorm = 0.0;
        for (Py_ssize_t i = j + 1; i < nx; i++) {
            xnorm += M[i * rows + j] * M[i * rows + j];
        }
        double norm = sqrt(alpha * alpha + xnorm);
        if (xnorm == 0.0 || norm == 0.0) {
            w->tau[j] = 0.0; /* already triangular in this column */
            continue;
        }
        double beta = alpha > 0.0 ? -norm : norm, scale = 1.0 / (alpha - beta);
        for (Py_ssize_t i = j + 1; i < nx; i++) {
            M[i * rows + j] *= scale;
        }
        w->tau[j] = (beta - alpha) / beta;
        M[j * rows + j] = beta;
        for (Py_ssize_t k = j + 1; k < rows; k++) {
            double dot = M[j * rows + k];
            for (Py_ssize_t i = j + 1; i < nx; i++) {
                dot += M[i * rows + j] * M[i * rows + k];
            }
            dot *= w->tau[j];
            M[j * rows + k] -= dot;
            for (Py_ssize_t i = j + 1; i < nx; i++) {
                M[i * rows + k] -= dot * M[i * rows + j];
            }
        }
    }
}

/* X (nx, cols) <- Q X = H_0 ... H_{rows-1} X, the reflections applied from the last one back. */
static void apply_q(const QRScratch *w, double *X, Py_ssize_t cols) {
    Py_ssize_t rows = w->rows, nx = w->nx;
    const double *M = w->M;
    for (Py_ssize_t j = rows - 1; j >= 0; j--) {
        double tau = w->tau[j];
        if (tau == 0.0) {
            continue;
        }
        for (Py_ssize_t k = 0; k < cols; k++) {
            double dot = X[j * cols + k];
            for (Py_ssize_t i = j + 1; i < nx; i++) {
                dot += M[i * rows + j] * X[i * cols + k];
            }
            dot *= tau;
            X[j * cols + k] -= dot;
            for (Py_ssize_t i = j + 1; i < nx; i++) {
                X[i * cols + k] -= dot * M[i * rows + j];
            }
        }
    }
}

/* One system: the scalings, the factorisation, the bound and, when certified, the response. */
static double certify_child(QRScratch *w, const double *A, const double *B, const double *c, double limit,
                            double *X_u, double *x_0, double *X_w) {
    Py_ssize_t rows = w->rows, nx = w->nx, m = w->m, width = rows + m + 1;
    for (Py_ssize_t i = 0; i < rows; i++) {
        double top = 0.0;
        for (Py_ssize_t j = 0; j < nx; j++) {
            top = fabs(A[i * nx + j]) > top ? fabs(A[i * nx + j]) : top;
        }
        w->r[i] = power_of_two_scale(top);
    }
    for (Py_ssize_t j = 0; j < nx; j++) {
        double top = 0.0;
        for (Py_ssize_t i = 0; i < rows; i++) {
            double v = fabs(A[i * nx + j]) * w->r[i];
            top = v > top ? v : top;
        }
        w->s[j] = power_of_two_scale(top);
    }
    double size = 0.0;
    for (Py_ssize_t i = 0; i < rows; i++) {
        for (Py_ssize_t j = 0; j < nx; j++) {
            double v = A[i * nx + j] * w->r[i] * w->s[j];
            w->M[j * rows + i] = v;
            size += v * v;
        }
    }
    size = sqrt(size);
    householder(w);
    for (Py_ssize_t j = 0; j < rows; j++) {
        if (!(size < limit * fabs(w->M[j * rows + j]))) {
            return HUGE_VAL; /* ||R_1^-1||_F >= 1 / |R_jj|: not certified */
        }
    }
    double *Y = w->Y, sum = 0.0;
    for (Py_ssize_t i = 0; i < rows; i++) { /* R_1^T Y = [I, diag(r) B, diag(r) c], R_1^T lower */
        double *y = Y + i * width;
        for (Py_ssize_t k = 0; k < width; k++) {
            y[k] = k < rows ? (k == i) : k < rows + m ? B[i * m + k - rows] * w->r[i] : c[i] * w->r[i];
        }
        for (Py_ssize_t l = 0; l < i; l++) {
            double a = w->M[l * rows + i];
            for (Py_ssize_t k = 0; k < width; k++) {
                y[k] -= a * Y[l * width + k];
            }
        }
        double d = w->M[i * rows + i];
        for (Py_ssize_t k = 0; k < width; k++) {
            y[k] /= d;
        }
        for (Py_ssize_t k = 0; k < rows; k++) {
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
            V[i * (m + 1) + k] = i < rows ? Y[i * width + rows + k] : 0.0;
        }
    }
    apply_q(w, V, m + 1);
    Py_ssize_t p = nx - rows; /* Q [0; I]: the null space */
    memset(X_w, 0, (size_t)(nx * p) * sizeof(double));
    for (Py_ssize_t k = 0; k < p; k++) {
        X_w[(rows + k) * p + k] = 1.0;
    }
    apply_q(w, X_w, p);
    for (Py_ssize_t i = 0; i < nx; i++) {
        for (Py_ssize_t k = 0; k < m; k++) {
            X_u[i * m + k] = V[i * (m + 1) + k] * w->s[i];
        }
        x_0[i] = V[i * (m + 1) + m] * w->s[i];
        for (Py_ssize_t k = 0; k < p; k++) {
            X_w[i * p + k] *= w->s[i];
        }
    }
    return bound;
}

static PyObject *certified_children(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 8) {
        PyErr_Format(kernel_error, "certified_children takes 8 arguments, got %zd", nargs);
        return NULL;
    }
    Buffer b[7];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    double *memory = NULL;
    Py_ssize_t a_shape[3] = {-1, -1, -1};
    if (take(args[0], &b[0], "A", 'd', 3, a_shape, 0)) goto done;
    Py_ssize_t count = a_shape[0], rows = a_shape[1], nx = a_shape[2];
    if (rows > nx || rows == 0) {
        PyErr_Format(kernel_error, "kernel buffer A: %zd rows and %zd columns, expected 0 < rows <= columns",
                     rows, nx);
        goto done;
    }
    Py_ssize_t b_shape[2] = {rows, -1}, c_shape[2] = {count, rows};
    if (take(args[1], &b[1], "B", 'd', 2, b_shape, 0) || take(args[2], &b[2], "c", 'd', 2, c_shape, 0)) goto done;
    Py_ssize_t m = b_shape[1];
    Py_ssize_t u_shape[3] = {count, nx, m}, x_shape[2] = {count, nx}, w_shape[3] = {count, nx, nx - rows};
    Py_ssize_t bound_shape[1] = {count};
    if (take(args[3], &b[3], "X_u", 'd', 3, u_shape, 1) || take(args[4], &b[4], "x_0", 'd', 2, x_shape, 1) ||
        take(args[5], &b[5], "X_w", 'd', 3, w_shape, 1) || take(args[6], &b[6], "bound", 'd', 1, bound_shape, 1))
        goto done;
    double limit = 0.0, *floats[1] = {&limit};
    static const char *float_names[1] = {"limit"};
    if (take_floats(args, 7, float_names, floats, 1)) goto done;
    Py_ssize_t width = rows + m + 1;
    memory = PyMem_Malloc((size_t)(nx * rows + rows + nx * (m + 1) + rows * width + rows + nx) * sizeof(double));
    if (memory == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    QRScratch w = {rows, nx, m, memory, NULL, NULL, NULL, NULL, NULL};
    w.tau = w.M + nx * rows, w.V = w.tau + rows, w.Y = w.V + nx * (m + 1), w.r = w.Y + rows * width, w.s = w.r + rows;
    const double *A = b[0].view.buf, *B = b[1].view.buf, *c = b[2].view.buf;
    double *X_u = b[3].view.buf, *x_0 = b[4].view.buf, *X_w = b[5].view.buf, *bound = b[6].view.buf;
    for (Py_ssize_t i = 0; i < count; i++) {
        bound[i] = certify_child(&w, A + i * rows * nx, B, c + i * rows, limit, X_u + i * nx * m, x_0 + i * nx,
                                 X_w + i * nx * (nx - rows));
    }
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(memory);
    release(b, 7);
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

#define QUERY_BUFFERS 15
static const char *query_names[QUERY_BUFFERS] = {"H_u", "h_0", "norms", "motion", "H_w1", "p", "rows",
                                                  "inequality_rows", "X_u", "X_w", "x_0", "K", "domain_tolerance",
                                                  "zero_row_tolerance", "radius_cap"};

/* The table's 12 buffers and 3 tolerances (args[0:15]), checked against one another; acc: 2k. */
static int take_query(PyObject *const *args, Buffer *b, QueryTable *t, Py_ssize_t acc) {
    Py_ssize_t hu[3] = {-1, -1, -1};
    if (take(args[0], &b[0], "H_u", 'd', 3, hu, 0)) return -1;
    t->modes = hu[0], t->width = hu[1], t->m = hu[2];
    Py_ssize_t fr[2] = {t->modes, t->width}, f1[1] = {t->modes}, xu[3] = {t->modes, -1, t->m};
    if (take(args[1], &b[1], "h_0", 'd', 2, fr, 0) || take(args[2], &b[2], "norms", 'd', 2, fr, 0) ||
        take(args[3], &b[3], "motion", '?', 2, fr, 0) || take(args[4], &b[4], "H_w1", 'd', 2, fr, 0) ||
        take(args[5], &b[5], "p", 'q', 1, f1, 0) || take(args[6], &b[6], "rows", 'q', 1, f1, 0) ||
        take(args[7], &b[7], "inequality_rows", 'q', 1, f1, 0) || take(args[8], &b[8], "X_u", 'd', 3, xu, 0))
        return -1;
    t->nx = xu[1];
    Py_ssize_t xw[3] = {t->modes, t->nx, -1}, x0[2] = {t->modes, t->nx}, k[3] = {t->modes, -1, t->nx + t->m + 1};
    if (take(args[9], &b[9], "X_w", 'd', 3, xw, 0) || take(args[10], &b[10], "x_0", 'd', 2, x0, 0) ||
        take(args[11], &b[11], "K", 'd', 3, k, 0))
        return -1;
    t->pmax = xw[2], t->krows = k[1], t->acc = acc;
    double *floats[3] = {&t->dt, &t->zrt, &t->cap};
    if (take_floats(args, 12, query_names + 12, floats, 3)) return -1;
    t->H_u = b[0].view.buf, t->h_0 = b[1].view.buf, t->norms = b[2].view.buf, t->motion = b[3].view.buf;
    t->H_w1 = b[4].view.buf, t->p = b[5].view.buf, t->rows = b[6].view.buf, t->ineq = b[7].view.buf;
    t->X_u = b[8].view.buf, t->X_w = b[9].view.buf, t->x_0 = b[10].view.buf, t->K = b[11].view.buf;
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

/* locate_points(table..., U, status, w): every point of U (N, m) against every mode. */
static PyObject *locate_points(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != QUERY_BUFFERS + 3) {
        PyErr_Format(kernel_error, "locate_points takes %d arguments, got %zd", QUERY_BUFFERS + 3, nargs);
        return NULL;
    }
    Buffer b[15];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    double *h = NULL;
    QueryTable t;
    if (take_query(args, b, &t, 0)) goto done;
    Py_ssize_t u_shape[2] = {-1, t.m};
    if (take(args[15], &b[12], "U", 'd', 2, u_shape, 0)) goto done;
    Py_ssize_t points = u_shape[0], out[2] = {points, t.modes};
    if (take(args[16], &b[13], "status", 'b', 2, out, 1) || take(args[17], &b[14], "w", 'd', 2, out, 1)) goto done;
    const double *U = b[12].view.buf;
    signed char *status = b[13].view.buf;
    double *w = b[14].view.buf;
    h = PyMem_Malloc((size_t)(t.width + 1) * sizeof(double));
    if (h == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t j = 0; j < points; j++) {
        for (Py_ssize_t i = 0; i < t.modes; i++) {
            status[j * t.modes + i] = locate_mode(&t, i, U + j * t.m, h, &w[j * t.modes + i]);
        }
    }
    Py_INCREF(Py_None);
    result = Py_None;
done:
    PyMem_Free(h);
    release(b, 15);
    return result;
}

/* evaluate_points(table..., U, point, index, w, x, acc, residual, violation): per solution s, mode
 * index[s] at U[point[s]] with the ambiguity values w[s] (p_max,). */
static PyObject *evaluate_points(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != QUERY_BUFFERS + 8) {
        PyErr_Format(kernel_error, "evaluate_points takes %d arguments, got %zd", QUERY_BUFFERS + 8, nargs);
        return NULL;
    }
    Buffer b[20];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    double *z = NULL;
    QueryTable t;
    Py_ssize_t acc_shape[2] = {-1, -1};
    if (take(args[20], &b[19], "acc", 'd', 2, acc_shape, 1) || take_query(args, b, &t, acc_shape[1])) goto done;
    Py_ssize_t u_shape[2] = {-1, t.m}, s_shape[1] = {acc_shape[0]}, w_shape[2] = {acc_shape[0], t.pmax};
    Py_ssize_t x_shape[2] = {acc_shape[0], t.nx};
    if (take(args[15], &b[12], "U", 'd', 2, u_shape, 0) || take(args[16], &b[13], "point", 'q', 1, s_shape, 0) ||
        take(args[17], &b[14], "index", 'q', 1, s_shape, 0) || take(args[18], &b[15], "w", 'd', 2, w_shape, 0) ||
        take(args[19], &b[16], "x", 'd', 2, x_shape, 1) || take(args[21], &b[17], "residual", 'd', 1, s_shape, 1) ||
        take(args[22], &b[18], "violation", 'd', 1, s_shape, 1))
        goto done;
    const double *U = b[12].view.buf, *W = b[15].view.buf;
    const long long *point = b[13].view.buf, *index = b[14].view.buf;
    double *X = b[16].view.buf, *acc = b[19].view.buf, *residual = b[17].view.buf, *violation = b[18].view.buf;
    Py_ssize_t count = s_shape[0];
    for (Py_ssize_t s = 0; s < count; s++) {
        if (index[s] < 0 || index[s] >= t.modes || point[s] < 0 || point[s] >= u_shape[0]) {
            PyErr_Format(kernel_error, "evaluate_points: solution %zd has mode %lld of %zd, point %lld of %zd", s,
                         index[s], t.modes, point[s], u_shape[0]);
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
    Py_INCREF(Py_None);
    result = Py_None;
done:
    PyMem_Free(z);
    release(b, 20);
    return result;
}

/* query_point(table..., u, status, w, x, acc, residual, violation): one input u (m,) against every
 * mode, each mode that holds it (QUERY_INSIDE) evaluated at its w into its row of x (modes, nx),
 * acc (modes, 2k), residual and violation (modes,). */
static PyObject *query_point(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != QUERY_BUFFERS + 7) {
        PyErr_Format(kernel_error, "query_point takes %d arguments, got %zd", QUERY_BUFFERS + 7, nargs);
        return NULL;
    }
    Buffer b[19];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    double *h = NULL;
    QueryTable t;
    Py_ssize_t acc_shape[2] = {-1, -1};
    if (take(args[19], &b[18], "acc", 'd', 2, acc_shape, 1) || take_query(args, b, &t, acc_shape[1])) goto done;
    Py_ssize_t u_shape[1] = {t.m}, f1[1] = {t.modes}, x_shape[2] = {t.modes, t.nx};
    if (acc_shape[0] != t.modes) {
        PyErr_Format(kernel_error, "kernel buffer acc: axis 0 has %zd entries, expected %zd", acc_shape[0], t.modes);
        goto done;
    }
    if (take(args[15], &b[12], "u", 'd', 1, u_shape, 0) || take(args[16], &b[13], "status", 'b', 1, f1, 1) ||
        take(args[17], &b[14], "w", 'd', 1, f1, 1) || take(args[18], &b[15], "x", 'd', 2, x_shape, 1) ||
        take(args[20], &b[16], "residual", 'd', 1, f1, 1) || take(args[21], &b[17], "violation", 'd', 1, f1, 1))
        goto done;
    const double *u = b[12].view.buf;
    signed char *status = b[13].view.buf;
    double *w = b[14].view.buf, *X = b[15].view.buf, *acc = b[18].view.buf;
    double *residual = b[16].view.buf, *violation = b[17].view.buf;
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
    Py_INCREF(Py_None);
    result = Py_None;
done:
    PyMem_Free(h);
    release(b, 19);
    return result;
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

static PyObject *lemke(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 8) {
        PyErr_Format(kernel_error, "lemke takes 8 arguments, got %zd", nargs);
        return NULL;
    }
    Buffer b[5];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    double *work = NULL;
    Py_ssize_t *index = NULL;
    Py_ssize_t q_shape[1] = {-1};
    if (take(args[1], &b[1], "q", 'd', 1, q_shape, 0)) {
        goto done;
    }
    Py_ssize_t n = q_shape[0], m_shape[2] = {n, n}, v_shape[1] = {n}, b_shape[2] = {n, n}, v2_shape[1] = {n};
    if (take(args[0], &b[0], "M", 'd', 2, m_shape, 0) || take(args[2], &b[2], "basis", 'q', 1, v_shape, 1) ||
        take(args[3], &b[3], "matrix", 'd', 2, b_shape, 1) || take(args[4], &b[4], "rhs", 'd', 1, v2_shape, 1)) {
        goto done;
    }
    long long max_pivots = PyLong_AsLongLong(args[5]);
    double pivot_tolerance = PyFloat_AsDouble(args[6]), tie = PyFloat_AsDouble(args[7]);
    if (PyErr_Occurred()) {
        goto done;
    }
    Py_ssize_t cols = 2 * n + 2;
    work = PyMem_Malloc((size_t)(n * cols + 5 * n + 1) * sizeof(double));
    index = PyMem_Malloc((size_t)(2 * n + 1) * sizeof(Py_ssize_t));
    if (work == NULL || index == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    const double *M = b[0].view.buf, *q = b[1].view.buf;
    Lemke L = {n, cols, work, work + n * cols, work + n * cols + n, work + n * cols + 2 * n,
               work + n * cols + 4 * n, index, index + n, b[2].view.buf, tie};
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
    double *matrix = b[3].view.buf, *rhs = b[4].view.buf;
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
    release(b, 5);
    return result;
}

/* coulomb_matrix: frcontrol.simulation.impact._coulomb_matrix of the Delassus matrix W (2c, 2c)
 * scaled by m_ref (each entry W_ij m_ref, negated where the block is): the LCP matrix (4c, 4c) in
 * z = (p_N, p_T+, p_T-, sigma), written into out, entry for entry as there. */
static PyObject *coulomb_matrix(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 4) {
        PyErr_Format(kernel_error, "coulomb_matrix takes 4 arguments, got %zd", nargs);
        return NULL;
    }
    Buffer b[3];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    Py_ssize_t mu_shape[1] = {-1};
    if (take(args[2], &b[1], "mu", 'd', 1, mu_shape, 0)) {
        goto done;
    }
    Py_ssize_t c = mu_shape[0], w_shape[2] = {2 * c, 2 * c}, out_shape[2] = {4 * c, 4 * c};
    if (take(args[0], &b[0], "W", 'd', 2, w_shape, 0) || take(args[3], &b[2], "out", 'd', 2, out_shape, 1)) {
        goto done;
    }
    double m_ref = PyFloat_AsDouble(args[1]);
    if (PyErr_Occurred()) {
        goto done;
    }
    const double *W = b[0].view.buf, *mu = b[1].view.buf;
    double *out = b[2].view.buf;
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
    Py_INCREF(Py_None);
    result = Py_None;
done:
    release(b, 3);
    return result;
}

/* lcp_check: frcontrol.lcp._verified's numbers for a candidate z of the LCP (M, q) with its
 * w = M z + q (computed by the caller, NumPy's product): the residual max_i |min(z_i, w_i)| and the
 * largest row bound, and whether every row is within its bound: tolerance * max((|M| |z|)_i,
 * ||q||_inf) (lcp_row_tolerances), or, for an enumerated candidate, tolerance * ||q||_inf
 * (lcp_enumeration_tolerance). The residual is NumPy's exactly; the bounds' sums run in index
 * order (the same to round-off); a NaN anywhere makes the residual NaN and the check fail. */
static PyObject *lcp_check_point(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 6) {
        PyErr_Format(kernel_error, "lcp_check takes 6 arguments, got %zd", nargs);
        return NULL;
    }
    Buffer b[4];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    Py_ssize_t q_shape[1] = {-1};
    if (take(args[1], &b[1], "q", 'd', 1, q_shape, 0)) {
        goto done;
    }
    Py_ssize_t n = q_shape[0], m_shape[2] = {n, n}, z_shape[1] = {n}, w_shape[1] = {n};
    if (take(args[0], &b[0], "M", 'd', 2, m_shape, 0) || take(args[2], &b[2], "z", 'd', 1, z_shape, 0) ||
        take(args[3], &b[3], "w", 'd', 1, w_shape, 0)) {
        goto done;
    }
    double tolerance = PyFloat_AsDouble(args[4]);
    int enumerated = PyObject_IsTrue(args[5]);
    if (PyErr_Occurred() || enumerated < 0) {
        goto done;
    }
    const double *M = b[0].view.buf, *q = b[1].view.buf, *z = b[2].view.buf, *w = b[3].view.buf;
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
    release(b, 4);
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

static PyObject *compliant_law(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 13) {
        PyErr_Format(kernel_error, "compliant_law takes 13 arguments, got %zd", nargs);
        return NULL;
    }
    static const char *names[13] = {"gaps", "normal_velocities", "tangential_velocities", "stretch", "mu",
                                    "stiffness", "damping", "tangential_stiffness", "tangential_damping",
                                    "lam_n", "lam_t", "rate", "status"};
    Buffer b[13];
    memset(b, 0, sizeof(b));
    PyObject *result = NULL;
    Py_ssize_t c = -1;
    for (int i = 0; i < 13; i++) {
        Py_ssize_t shape[1] = {c};
        if (take(args[i], &b[i], names[i], i == 12 ? 'q' : 'd', 1, shape, i >= 9)) {
            goto done;
        }
        c = shape[0];
    }
    const double *gaps = b[0].view.buf, *vn = b[1].view.buf, *vt = b[2].view.buf, *s = b[3].view.buf;
    const double *mu = b[4].view.buf, *k_n = b[5].view.buf, *b_n = b[6].view.buf, *k_t = b[7].view.buf;
    const double *b_t = b[8].view.buf;
    double *lam_n = b[9].view.buf, *lam_t = b[10].view.buf, *rate = b[11].view.buf;
    long long *status = b[12].view.buf;
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
    Py_INCREF(Py_None);
    result = Py_None;
done:
    release(b, 13);
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
    {"margin_rows", (PyCFunction)(void (*)(void))margin_rows, METH_FASTCALL,
     "margin_rows(G, X_u, X_w, x_0, g, C, d, motion, out, h_out, zero_row_tolerance, domain_tolerance)\n"
     "-> int\n\n"
     "The motion LP's rows of a mode's domain (frcontrol.engine.domain_rows and motion_margin) written\n"
     "into out (rows, m + p + 1) and h_out (rows,): -1 when a constant motion row is violated, else\n"
     "1 (a constant motion row is not strict) + 2 (some motion row is moving)."},
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
    {"compliant_law", (PyCFunction)(void (*)(void))compliant_law, METH_FASTCALL,
     "compliant_law(gaps, v_N, v_T, stretch, mu, k_N, b_N, k_T, b_T, lam_n, lam_t, rate, status) -> None\n\n"
     "frcontrol.simulation.compliant.contact_forces without contact zones: lam_N, lam_T, the stretch\n"
     "rates and the status (int64: 0 open, 1 stick, 2 slip) written into the last four arrays (c,)."},
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
    const char *names[16] = {"NOT_CERTIFIED", "CERTIFIED_INADMISSIBLE", "CERTIFIED_ADMISSIBLE", "INADMISSIBLE",
                             "ADMISSIBLE", "NEEDS_PYTHON", "ADMISSIBLE_W", "MOVES_NONE", "MOVES_FORCES",
                             "MOVES_ACCELERATIONS", "QUERY_OUTSIDE", "QUERY_INSIDE", "QUERY_NEEDS_PYTHON", "LEMKE_SOLVED", "LEMKE_RAY",
                             "LEMKE_MAX_PIVOTS"};
    int values[16] = {NOT_CERTIFIED, CERTIFIED_INADMISSIBLE, CERTIFIED_ADMISSIBLE, INADMISSIBLE, ADMISSIBLE,
                      NEEDS_PYTHON, ADMISSIBLE_W, MOVES_NONE, MOVES_FORCES, MOVES_ACCELERATIONS,
                      QUERY_OUTSIDE, QUERY_INSIDE, QUERY_NEEDS_PYTHON, LEMKE_SOLVED, LEMKE_RAY,
                      LEMKE_MAX_PIVOTS};
    PyObject *all = Py_BuildValue("[ssssssssssssss]", "certified_modes", "rank_modes", "lp_check", "robot_state",
                                  "contact_rows", "margin_rows", "certified_children", "locate_points",
                                  "evaluate_points", "query_point", "lemke", "coulomb_matrix", "lcp_check",
                                  "compliant_law");
    if (all == NULL) {
        Py_DECREF(mod);
        return NULL;
    }
    for (int i = 0; i < 16; i++) {
        PyObject *name = PyUnicode_FromString(names[i]);
        int failed = name == NULL || PyList_Append(all, name) != 0 ||
                     PyModule_AddIntConstant(mod, names[i], values[i]) != 0;
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
