/* anadyn_generic: the recursions over a robot's numeric tables, compiled once per
   installation (not per robot); see anadyn_cli/numeric/generic/__init__.py.

   Tables (built by generic.tables.pack):
     ints  I = [NB, N, NM, MODE, then per body: parent (-1: the world), kind
               (0 fixed, 1 revolute, 2 prismatic), joint (moving index, -1)]
     doubles D = [gravity (3), per body BODY doubles: C^T (9, row-major: parent
               axes -> joint axes), origin (3), axis (3), mass, h = m c (3),
               I_O (9, about the origin); per moving joint PASSIVE doubles:
               damping, friction, friction_velocity, stiffness, rest; the joint
               map theta = A q + c: A (NM x N), c (NM); with MODE 1 A^-1 (N x NM)]
   MODE: 0 A = 1 (theta = q + c), 1 A square and invertible, 2 otherwise (the
   accelerations by CRBA and a dense Cholesky factorization of M = A^T H A).

   Spatial vectors (angular, linear) at the body origin in body axes; gravity as
   the base's acceleration a_0 = (0, -g).  All functions return 0, or 1 when M is
   not positive definite, 2 when a result is not finite. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BODY 28
#define PASSIVE 5

typedef struct {
    int nb, n, nm, mode;
    const int *parent, *kind, *joint;      /* stride 3 from ints + 4 */
    const double *g, *body, *passive, *A, *c, *Ainv;
} Model;

typedef struct {                           /* per body, at one q */
    double E[9], r[3];
} Frame;

static void model_of(const int *I, const double *D, Model *m) {
    m->nb = I[0]; m->n = I[1]; m->nm = I[2]; m->mode = I[3];
    m->parent = I + 4; m->kind = I + 5; m->joint = I + 6;
    m->g = D;
    m->body = D + 3;
    m->passive = m->body + BODY * m->nb;
    m->A = m->passive + PASSIVE * m->nm;
    m->c = m->A + m->nm * m->n;
    m->Ainv = m->c + m->nm;
}

#define PARENT(m, i) ((m)->parent[3 * (i)])
#define KIND(m, i) ((m)->kind[3 * (i)])
#define JOINT(m, i) ((m)->joint[3 * (i)])

static size_t ints_needed(int nb) { return 4 + 3 * (size_t)nb; }

static size_t doubles_needed(int nb, int n, int nm, int mode) {
    return 3 + (size_t)BODY * nb + (size_t)PASSIVE * nm + (size_t)nm * n + nm
           + (mode == 1 ? (size_t)n * nm : 0);
}

/* theta = A q + c, dtheta = A dq */
static void joint_map(const Model *m, const double *q, double *out, int offset) {
    if (m->mode == 0) {
        for (int j = 0; j < m->nm; j++) out[j] = offset ? q[j] + m->c[j] : q[j];
        return;
    }
    for (int j = 0; j < m->nm; j++) {
        double v = offset ? m->c[j] : 0.0;
        for (int k = 0; k < m->n; k++) v += m->A[j * m->n + k] * q[k];
        out[j] = v;
    }
}

/* E = Rot(a, theta)^T C^T (revolute) or C^T; r = origin (+ C a theta, prismatic),
   for every body (only: those marked) */
static void frames(const Model *m, const double *theta, Frame *F, const int *only) {
    for (int i = 0; i < m->nb; i++) {
        if (only && !only[i]) continue;
        const double *b = m->body + BODY * i, *CT = b, *o = b + 9, *a = b + 12;
        Frame *f = F + i;
        memcpy(f->E, CT, sizeof(double) * 9);
        memcpy(f->r, o, sizeof(double) * 3);
        if (KIND(m, i) == 1) {
            double th = theta[JOINT(m, i)], cs = cos(th), sn = sin(th), RT[9];
            for (int r = 0; r < 3; r++)
                for (int k = 0; k < 3; k++)
                    RT[3 * r + k] = (r == k ? cs : 0.0) + (1.0 - cs) * a[r] * a[k];
            RT[1] += sn * a[2]; RT[2] -= sn * a[1];      /* - s [a]x */
            RT[3] -= sn * a[2]; RT[5] += sn * a[0];
            RT[6] += sn * a[1]; RT[7] -= sn * a[0];
            for (int r = 0; r < 3; r++)
                for (int k = 0; k < 3; k++)
                    f->E[3 * r + k] = RT[3 * r] * CT[k] + RT[3 * r + 1] * CT[3 + k]
                                      + RT[3 * r + 2] * CT[6 + k];
        } else if (KIND(m, i) == 2) {
            double th = theta[JOINT(m, i)];
            for (int r = 0; r < 3; r++)          /* C a = (C^T)^T a */
                f->r[r] += th * (CT[r] * a[0] + CT[3 + r] * a[1] + CT[6 + r] * a[2]);
        }
    }
}

static void cross3(const double *a, const double *b, double *o) {
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static void mv3(const double *E, const double *v, double *o) {
    for (int r = 0; r < 3; r++) o[r] = E[3 * r] * v[0] + E[3 * r + 1] * v[1] + E[3 * r + 2] * v[2];
}

static void mtv3(const double *E, const double *v, double *o) {
    for (int r = 0; r < 3; r++) o[r] = E[r] * v[0] + E[3 + r] * v[1] + E[6 + r] * v[2];
}

/* a motion vector of the parent in the child's axes: (E w, E (v - r x w)) */
static void motion_in(const Frame *f, const double *p, double *o) {
    double rw[3], d[3];
    cross3(f->r, p, rw);
    for (int k = 0; k < 3; k++) d[k] = p[3 + k] - rw[k];
    mv3(f->E, p, o);
    mv3(f->E, d, o + 3);
}

/* a force of the child in the parent's axes: (E^T n + r x E^T f, E^T f) */
static void force_out(const Frame *f, const double *c, double *o) {
    double rf[3];
    mtv3(f->E, c + 3, o + 3);
    cross3(f->r, o + 3, rf);
    mtv3(f->E, c, o);
    for (int k = 0; k < 3; k++) o[k] += rf[k];
}

/* v x m: (w x mw, w x mv + v x mw) */
static void cross_motion(const double *v, const double *m, double *o) {
    double t[3];
    cross3(v, m, o);
    cross3(v, m + 3, o + 3);
    cross3(v + 3, m, t);
    for (int k = 0; k < 3; k++) o[3 + k] += t[k];
}

/* v x* f: (w x n + v x f, w x f) */
static void cross_force(const double *v, const double *f, double *o) {
    double t[3];
    cross3(v, f, o);
    cross3(v + 3, f + 3, t);
    for (int k = 0; k < 3; k++) o[k] += t[k];
    cross3(v, f + 3, o + 3);
}

/* the body's spatial inertia about its origin, 6x6 row-major: [[I_O, [h]x], [[h]x^T, m 1]] */
static void inertia(const double *b, double *I6) {
    const double m = b[15], *h = b + 16, *IO = b + 19;
    memset(I6, 0, sizeof(double) * 36);
    for (int r = 0; r < 3; r++) {
        for (int k = 0; k < 3; k++) I6[6 * r + k] = IO[3 * r + k];
        I6[6 * (3 + r) + 3 + r] = m;
    }
    double hx[9] = {0, -h[2], h[1], h[2], 0, -h[0], -h[1], h[0], 0};
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 3; k++) {
            I6[6 * r + 3 + k] = hx[3 * r + k];
            I6[6 * (3 + k) + r] = hx[3 * r + k];
        }
}

static void mv6(const double *M, const double *v, double *o) {
    for (int r = 0; r < 6; r++) {
        double s = 0.0;
        for (int k = 0; k < 6; k++) s += M[6 * r + k] * v[k];
        o[r] = s;
    }
}

/* the motion subspace S of body i (6-vector; zero for a fixed joint) */
static void subspace(const Model *m, int i, double *S) {
    const double *a = m->body + BODY * i + 12;
    memset(S, 0, sizeof(double) * 6);
    if (KIND(m, i) == 1) memcpy(S, a, sizeof(double) * 3);
    else if (KIND(m, i) == 2) memcpy(S + 3, a, sizeof(double) * 3);
}

static void mm3(const double *a, const double *b, double *o) {      /* o = a b */
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            o[3 * i + k] = a[3 * i] * b[k] + a[3 * i + 1] * b[3 + k] + a[3 * i + 2] * b[6 + k];
}

static void mtm3(const double *a, const double *b, double *o) {     /* o = a^T b */
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            o[3 * i + k] = a[i] * b[k] + a[3 + i] * b[3 + k] + a[6 + i] * b[6 + k];
}

/* P += X^T Ia X for the frame's X = R T, R = diag(E, E), T = [[1, 0], [-[r]x, 1]]:
   with R^T Ia R = [[A, B], [B^T, C]] (3x3 blocks), X^T Ia X =
   [[A - B rx + rx B^T - rx C rx, B + rx C], [B^T - C rx, C]], rx = [r]x */
static void add_congruence(const Frame *f, const double *Ia, double *P) {
    double blk[3][9], rot[3][9], t[9], rx[9], Brx[9], rxC[9], rxCrx[9];
    const double *r = f->r;
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            blk[0][3 * i + k] = Ia[6 * i + k];              /* A */
            blk[1][3 * i + k] = Ia[6 * i + 3 + k];          /* B */
            blk[2][3 * i + k] = Ia[6 * (3 + i) + 3 + k];    /* C */
        }
    for (int b = 0; b < 3; b++) {
        mm3(blk[b], f->E, t);
        mtm3(f->E, t, rot[b]);
    }
    rx[0] = 0; rx[1] = -r[2]; rx[2] = r[1]; rx[3] = r[2]; rx[4] = 0; rx[5] = -r[0];
    rx[6] = -r[1]; rx[7] = r[0]; rx[8] = 0;
    const double *A = rot[0], *B = rot[1], *C = rot[2];
    mm3(B, rx, Brx);
    mm3(rx, C, rxC);
    mm3(rxC, rx, rxCrx);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            /* rx B^T = -(B rx)^T since rx^T = -rx */
            P[6 * i + k] += A[3 * i + k] - Brx[3 * i + k] - Brx[3 * k + i] - rxCrx[3 * i + k];
            P[6 * i + 3 + k] += B[3 * i + k] + rxC[3 * i + k];
            P[6 * (3 + k) + i] += B[3 * i + k] + rxC[3 * i + k];
            P[6 * (3 + i) + 3 + k] += C[3 * i + k];
        }
}

static double dot6(const double *a, const double *b) {
    double s = 0.0;
    for (int k = 0; k < 6; k++) s += a[k] * b[k];
    return s;
}

/* tau_passive = -damping dtheta - friction tanh(dtheta / v) - stiffness (theta - rest) */
static double passive_of(const Model *m, int j, double theta, double dtheta) {
    const double *p = m->passive + PASSIVE * j;
    double v = 0.0;
    if (p[0] != 0.0) v -= p[0] * dtheta;
    if (p[1] != 0.0) v -= p[1] * tanh(dtheta / p[2]);
    if (p[3] != 0.0) v -= p[3] * (theta - p[4]);
    return v;
}

static void passive(const Model *m, const double *theta, const double *dtheta, double *out) {
    for (int j = 0; j < m->nm; j++) out[j] = passive_of(m, j, theta[j], dtheta[j]);
}

/* velocities of every body (6 per body; only: of those marked, the others' left
   as they are) and, with ddtheta, accelerations; with f, the body forces
   I a + v x* I v (gravity in a through a_0) */
static void forward_pass(const Model *m, const Frame *F, const double *dtheta,
                         const double *ddtheta, double *v, double *a, double *f,
                         const int *only) {
    for (int i = 0; i < m->nb; i++) {
        if (only && !only[i]) continue;
        double S[6], t[6];
        int p = PARENT(m, i), j = JOINT(m, i);
        subspace(m, i, S);
        if (p < 0) {
            double w0[6] = {0, 0, 0, 0, 0, 0}, a0[6] = {0, 0, 0, -m->g[0], -m->g[1], -m->g[2]};
            motion_in(F + i, w0, v + 6 * i);
            if (a) motion_in(F + i, a0, a + 6 * i);
        } else {
            motion_in(F + i, v + 6 * p, v + 6 * i);
            if (a) motion_in(F + i, a + 6 * p, a + 6 * i);
        }
        if (j >= 0) {
            double sd[6];
            for (int k = 0; k < 6; k++) sd[k] = S[k] * dtheta[j];
            if (a) {
                cross_motion(v + 6 * i, sd, t);          /* v_before x S dtheta */
                for (int k = 0; k < 6; k++) a[6 * i + k] += t[k] + S[k] * ddtheta[j];
            }
            for (int k = 0; k < 6; k++) v[6 * i + k] += sd[k];
        }
        if (f) {
            double I6[36], Iv[6];
            inertia(m->body + BODY * i, I6);
            mv6(I6, a + 6 * i, f + 6 * i);
            mv6(I6, v + 6 * i, Iv);
            cross_force(v + 6 * i, Iv, t);
            for (int k = 0; k < 6; k++) f[6 * i + k] += t[k];
        }
    }
}

/* joint forces S^T f of the rigid bodies (leaves to root; f is consumed) */
static void backward_pass(const Model *m, const Frame *F, double *f, double *tau) {
    for (int i = m->nb - 1; i >= 0; i--) {
        int p = PARENT(m, i), j = JOINT(m, i);
        if (j >= 0) {
            double S[6];
            subspace(m, i, S);
            tau[j] = dot6(S, f + 6 * i);
        }
        if (p >= 0) {
            double t[6];
            force_out(F + i, f + 6 * i, t);
            for (int k = 0; k < 6; k++) f[6 * p + k] += t[k];
        }
    }
}

/* A^T (S^T f - tau_passive): the generalized forces of the body forces f
   (consumed) at joint displacements th and rates dth; tau, pas: NM scratch */
static void generalized(const Model *m, const Frame *F, double *f, const double *th,
                        const double *dth, double *tau, double *pas, double *out) {
    backward_pass(m, F, f, tau);
    passive(m, th, dth, pas);
    if (m->mode == 0) {
        for (int k = 0; k < m->n; k++) out[k] = tau[k] - pas[k];
        return;
    }
    for (int k = 0; k < m->n; k++) {
        double s = 0.0;
        for (int j = 0; j < m->nm; j++) s += m->A[j * m->n + k] * (tau[j] - pas[j]);
        out[k] = s;
    }
}

/* ID = A^T (tau_rigid(q, dq, ddq) - tau_passive) = M ddq - F */
static int inverse(const Model *m, const double *q, const double *dq, const double *ddq,
                   double *out) {
    int nb = m->nb, nm = m->nm;
    Frame *F = malloc(sizeof(Frame) * nb);
    double *w = malloc(sizeof(double) * (18 * nb + 5 * nm + 1));
    if (!F || !w) { free(F); free(w); return 1; }
    double *v = w, *a = v + 6 * nb, *f = a + 6 * nb, *th = f + 6 * nb, *dth = th + nm,
           *ddth = dth + nm, *tau = ddth + nm, *pas = tau + nm;
    joint_map(m, q, th, 1);
    joint_map(m, dq, dth, 0);
    joint_map(m, ddq, ddth, 0);
    frames(m, th, F, NULL);
    forward_pass(m, F, dth, ddth, v, a, f, NULL);
    generalized(m, F, f, th, dth, tau, pas, out);
    free(F); free(w);
    return 0;
}

/* H (NM x NM, joint space) by composite rigid bodies */
static void crba_joint(const Model *m, const Frame *F, double *H) {
    int nb = m->nb, nm = m->nm;
    double *Ic = malloc(sizeof(double) * 36 * nb);
    memset(H, 0, sizeof(double) * nm * nm);
    if (!Ic) return;
    for (int i = 0; i < nb; i++) inertia(m->body + BODY * i, Ic + 36 * i);
    for (int i = nb - 1; i >= 0; i--) {
        int p = PARENT(m, i), j = JOINT(m, i);
        if (j >= 0) {
            double S[6], f[6], t[6];
            subspace(m, i, S);
            mv6(Ic + 36 * i, S, f);
            H[j * nm + j] = dot6(S, f);
            for (int b = i; PARENT(m, b) >= 0;) {
                force_out(F + b, f, t);
                memcpy(f, t, sizeof t);
                b = PARENT(m, b);
                int jb = JOINT(m, b);
                if (jb >= 0) {
                    double Sb[6];
                    subspace(m, b, Sb);
                    H[j * nm + jb] = H[jb * nm + j] = dot6(Sb, f);
                }
            }
        }
        if (p >= 0) add_congruence(F + i, Ic + 36 * i, Ic + 36 * p);
    }
    free(Ic);
}

/* M = A^T H A (N x N; H itself when A = 1); AH: NM x N scratch */
static void mass(const Model *m, const double *H, double *M, double *HA) {
    int n = m->n, nm = m->nm;
    if (m->mode == 0) { memcpy(M, H, sizeof(double) * n * n); return; }
    for (int j = 0; j < nm; j++)
        for (int c = 0; c < n; c++) {
            double s = 0.0;
            for (int k = 0; k < nm; k++) s += H[j * nm + k] * m->A[k * n + c];
            HA[j * n + c] = s;
        }
    for (int r = 0; r < n; r++)
        for (int c = 0; c < n; c++) {
            double s = 0.0;
            for (int j = 0; j < nm; j++) s += m->A[j * n + r] * HA[j * n + c];
            M[r * n + c] = s;
        }
}

/* M = L L^T in place (L in the lower triangle); 1 if not positive definite */
static int cholesky(double *M, int n) {
    for (int j = 0; j < n; j++) {
        double d = M[j * n + j];
        for (int k = 0; k < j; k++) d -= M[j * n + k] * M[j * n + k];
        if (!(d > 0.0)) return 1;
        d = sqrt(d);
        M[j * n + j] = d;
        for (int i = j + 1; i < n; i++) {
            double s = M[i * n + j];
            for (int k = 0; k < j; k++) s -= M[i * n + k] * M[j * n + k];
            M[i * n + j] = s / d;
        }
    }
    return 0;
}

/* M = L^T L in place for a mass matrix whose row j couples only joint j's
   ancestors lam (tree order, parents first: A = 1), L in the lower triangle
   (Featherstone's LTL factorization, no fill-in); 1 if not positive definite */
static int tree_factor(double *M, const int *lam, int n) {
    for (int k = n - 1; k >= 0; k--) {
        double d = M[k * n + k];
        if (!(d > 0.0)) return 1;
        d = sqrt(d);
        M[k * n + k] = d;
        for (int i = lam[k]; i >= 0; i = lam[i]) M[k * n + i] /= d;
        for (int i = lam[k]; i >= 0; i = lam[i])
            for (int j = i; j >= 0; j = lam[j]) M[i * n + j] -= M[k * n + i] * M[k * n + j];
    }
    return 0;
}

/* b = (L^T L)^-1 b in place (``tree_factor``) */
static void tree_solve(const double *L, const int *lam, double *b, int n) {
    for (int k = n - 1; k >= 0; k--) {
        b[k] /= L[k * n + k];
        for (int i = lam[k]; i >= 0; i = lam[i]) b[i] -= L[k * n + i] * b[k];
    }
    for (int k = 0; k < n; k++) {
        for (int i = lam[k]; i >= 0; i = lam[i]) b[k] -= L[k * n + i] * b[i];
        b[k] /= L[k * n + k];
    }
}

/* b = (L L^T)^-1 b in place */
static void cholesky_solve(const double *M, double *b, int n) {
    for (int i = 0; i < n; i++) {
        double s = b[i];
        for (int k = 0; k < i; k++) s -= M[i * n + k] * b[k];
        b[i] = s / M[i * n + i];
    }
    for (int i = n - 1; i >= 0; i--) {
        double s = b[i];
        for (int k = i + 1; k < n; k++) s -= M[k * n + i] * b[k];
        b[i] = s / M[i * n + i];
    }
}

/* ddtheta by the articulated-body algorithm for the joint forces tau (NM) */
static int aba_joint(const Model *m, const Frame *F, const double *dth, const double *tau,
                     double *ddth) {
    int nb = m->nb;
    double *w = malloc(sizeof(double) * (6 * nb * 5 + 36 * nb + 2 * nb));
    if (!w) return 1;
    double *v = w, *c = v + 6 * nb, *pA = c + 6 * nb, *U = pA + 6 * nb, *a = U + 6 * nb,
           *IA = a + 6 * nb, *Dinv = IA + 36 * nb, *u = Dinv + nb;
    for (int i = 0; i < nb; i++) {
        double S[6], Iv[6], sd[6];
        int p = PARENT(m, i), j = JOINT(m, i);
        if (p < 0) { double z[6] = {0}; motion_in(F + i, z, v + 6 * i); }
        else motion_in(F + i, v + 6 * p, v + 6 * i);
        memset(c + 6 * i, 0, sizeof(double) * 6);
        if (j >= 0) {
            subspace(m, i, S);
            for (int k = 0; k < 6; k++) sd[k] = S[k] * dth[j];
            cross_motion(v + 6 * i, sd, c + 6 * i);
            for (int k = 0; k < 6; k++) v[6 * i + k] += sd[k];
        }
        inertia(m->body + BODY * i, IA + 36 * i);
        mv6(IA + 36 * i, v + 6 * i, Iv);
        cross_force(v + 6 * i, Iv, pA + 6 * i);
    }
    for (int i = nb - 1; i >= 0; i--) {
        int p = PARENT(m, i), j = JOINT(m, i);
        double *I6 = IA + 36 * i, Ia[36], pa[6], t[6];
        memcpy(Ia, I6, sizeof Ia);
        if (j >= 0) {
            double S[6];
            subspace(m, i, S);
            mv6(I6, S, U + 6 * i);
            double D = dot6(S, U + 6 * i);
            if (!(D > 0.0)) { free(w); return 1; }
            Dinv[i] = 1.0 / D;
            u[i] = tau[j] - dot6(S, pA + 6 * i);
            for (int r = 0; r < 6; r++)
                for (int k = 0; k < 6; k++) Ia[6 * r + k] -= U[6 * i + r] * U[6 * i + k] * Dinv[i];
        }
        if (p < 0) continue;
        mv6(Ia, c + 6 * i, pa);
        for (int k = 0; k < 6; k++) pa[k] += pA[6 * i + k] + (j >= 0 ? U[6 * i + k] * Dinv[i] * u[i] : 0.0);
        add_congruence(F + i, Ia, IA + 36 * p);
        force_out(F + i, pa, t);
        for (int k = 0; k < 6; k++) pA[6 * p + k] += t[k];
    }
    for (int i = 0; i < nb; i++) {
        int p = PARENT(m, i), j = JOINT(m, i);
        if (p < 0) {
            double a0[6] = {0, 0, 0, -m->g[0], -m->g[1], -m->g[2]};
            motion_in(F + i, a0, a + 6 * i);
        } else motion_in(F + i, a + 6 * p, a + 6 * i);
        for (int k = 0; k < 6; k++) a[6 * i + k] += c[6 * i + k];
        if (j >= 0) {
            double S[6];
            subspace(m, i, S);
            ddth[j] = (u[i] - dot6(U + 6 * i, a + 6 * i)) * Dinv[i];
            for (int k = 0; k < 6; k++) a[6 * i + k] += S[k] * ddth[j];
        }
    }
    free(w);
    return 0;
}

static int finite_all(const double *v, int k) {
    for (int i = 0; i < k; i++) if (!isfinite(v[i])) return 0;
    return 1;
}

/* ddq solving M ddq = A^T (e + tau_passive - bias): e the joint efforts of the
   actuators (NM); by ABA (MODE 0, 1) or CRBA + Cholesky (MODE 2) */
static int accelerations(const Model *m, const double *x, const double *e, double *ddq) {
    int n = m->n, nm = m->nm, nb = m->nb, code = 0;
    Frame *F = malloc(sizeof(Frame) * nb);
    double *w = malloc(sizeof(double) * (5 * nm + nm * nm + nm * n + n * n + 18 * nb + 1));
    if (!F || !w) { free(F); free(w); return 1; }
    double *th = w, *dth = th + nm, *tau = dth + nm, *ddth = tau + nm, *bias = ddth + nm,
           *H = bias + nm, *M = H + nm * nm, *HA = M + n * n, *scratch = HA + nm * n;
    joint_map(m, x, th, 1);
    joint_map(m, x + n, dth, 0);
    frames(m, th, F, NULL);
    passive(m, th, dth, tau);
    for (int j = 0; j < nm; j++) tau[j] += e[j];
    if (m->mode != 2) {
        code = aba_joint(m, F, dth, tau, ddth);
        if (!code) {
            if (m->mode == 0) memcpy(ddq, ddth, sizeof(double) * n);
            else
                for (int k = 0; k < n; k++) {
                    double s = 0.0;
                    for (int j = 0; j < nm; j++) s += m->Ainv[k * nm + j] * ddth[j];
                    ddq[k] = s;
                }
        }
    } else {
        double *v = scratch, *a = v + 6 * nb, *f = a + 6 * nb;
        memset(ddth, 0, sizeof(double) * nm);
        forward_pass(m, F, dth, ddth, v, a, f, NULL);
        backward_pass(m, F, f, bias);
        crba_joint(m, F, H);
        mass(m, H, M, HA);
        for (int k = 0; k < n; k++) {
            double s = 0.0;
            for (int j = 0; j < nm; j++) s += m->A[j * n + k] * (tau[j] - bias[j]);
            ddq[k] = s;
        }
        code = cholesky(M, n);
        if (!code) cholesky_solve(M, ddq, n);
    }
    free(F); free(w);
    if (code) return code;
    return finite_all(ddq, n) ? 0 : 2;
}

/* The joint forces tau (NM) after the bodies marked in mask moved: their new
   frames Fk and body forces fk (fk of the others: as in the base state), the base
   state's frames F, accumulated forces acc and joint forces tau0.  Leaves to root,
   the marked bodies' forces are accumulated anew; the change they bring to an
   unmarked ancestor (d, where has) is carried up to the root. */
static void moved_forces(const Model *m, const int *mask, const Frame *F, const Frame *Fk,
                         double *fk, const double *acc, const double *tau0, double *d,
                         int *has, double *tau) {
    memcpy(tau, tau0, sizeof(double) * m->nm);
    memset(has, 0, sizeof(int) * m->nb);
    for (int i = m->nb - 1; i >= 0; i--) {
        int p = PARENT(m, i), j = JOINT(m, i);
        double S[6], t[6], t0[6];
        if (!mask[i] && !has[i]) continue;
        subspace(m, i, S);
        if (mask[i]) {
            if (j >= 0) tau[j] = dot6(S, fk + 6 * i);
            if (p < 0) continue;
            force_out(Fk + i, fk + 6 * i, t);
            if (mask[p]) { for (int k = 0; k < 6; k++) fk[6 * p + k] += t[k]; continue; }
            force_out(F + i, acc + 6 * i, t0);
            for (int k = 0; k < 6; k++) t[k] -= t0[k];
        } else {
            if (j >= 0) tau[j] = tau0[j] + dot6(S, d + 6 * i);
            if (p < 0) continue;
            force_out(F + i, d + 6 * i, t);
        }
        if (!has[p]) { memset(d + 6 * p, 0, sizeof(double) * 6); has[p] = 1; }
        for (int k = 0; k < 6; k++) d[6 * p + k] += t[k];
    }
}

/* J = [[0, 1], [M^-1 K]] (2N x 2N) at fixed joint efforts e: K = -dID/dx at fixed
   ddq, column by column by central differences of the recursive Newton-Euler
   algorithm (step 6e-6 max(1, |x_k|)) redone only on the bodies that a
   coordinate moves (their subtrees, and the change of force up to the root),
   then solved with the factor of M (composite rigid bodies; with A = 1 the
   tree's LTL factor, else a dense Cholesky factor) */
static int jacobian(const Model *m, const double *x, const double *e, double *J) {
    int n = m->n, nm = m->nm, nb = m->nb, n2 = 2 * n, code;
    Frame *F = malloc(sizeof(Frame) * 2 * nb);
    int *mask = malloc(sizeof(int) * (3 * nb + nm));
    double *w = malloc(sizeof(double) * (4 * n + n2 + 9 * nm + 54 * nb + nm * nm + nm * n + n * n));
    if (!F || !mask || !w) { free(F); free(mask); free(w); return 1; }
    Frame *Fk = F + nb;
    int *has = mask + nb, *own = has + nb, *lam = own + nb;
    double *ddq = w, *moved = ddq + n, *back = moved + n, *col = back + n,
           *xp = col + n,
           *th = xp + n2, *dth = th + nm, *ddth = dth + nm, *thk = ddth + nm, *dthk = thk + nm,
           *tau = dthk + nm, *tau0 = tau + nm, *pas = tau0 + nm, *pas0 = pas + nm, *v = pas0 + nm, *a = v + 6 * nb,
           *f = a + 6 * nb, *vk = f + 6 * nb, *ak = vk + 6 * nb, *fk = ak + 6 * nb,
           *acc = fk + 6 * nb, *d = acc + 6 * nb, *H = d + 6 * nb,
           *HA = H + nm * nm, *M = HA + nm * n;
    code = accelerations(m, x, e, ddq);
    if (!code) {
        joint_map(m, x, th, 1);
        joint_map(m, x + n, dth, 0);
        joint_map(m, ddq, ddth, 0);
        frames(m, th, F, NULL);
        forward_pass(m, F, dth, ddth, v, a, f, NULL);
        memcpy(acc, f, sizeof(double) * 6 * nb);
        backward_pass(m, F, acc, tau0);
        passive(m, th, dth, pas0);
        crba_joint(m, F, H);
        mass(m, H, M, HA);
        for (int i = 0; i < nb; i++) {      /* each joint's nearest moving ancestor */
            int j = JOINT(m, i), p = PARENT(m, i);
            while (p >= 0 && JOINT(m, p) < 0) p = PARENT(m, p);
            if (j >= 0) lam[j] = p < 0 ? -1 : JOINT(m, p);
        }
        code = m->mode == 0 ? tree_factor(M, lam, n) : cholesky(M, n);
    }
    memset(J, 0, sizeof(double) * n2 * n2);
    for (int i = 0; i < n; i++) J[i * n2 + n + i] = 1.0;
    memcpy(xp, x, sizeof(double) * n2);
    memcpy(Fk, F, sizeof(Frame) * nb);
    memcpy(vk, v, sizeof(double) * 18 * nb);          /* v, a, f: contiguous */
    for (int k = 0; k < n2 && !code; k++) {
        int c = k % n;
        for (int i = 0; i < nb; i++) {
            int j = JOINT(m, i), p = PARENT(m, i);
            own[i] = j >= 0 && m->A[j * n + c] != 0.0;
            mask[i] = own[i] || (p >= 0 && mask[p]);
        }
        double step = 6e-6 * fmax(1.0, fabs(x[k])), h = 0.0;
        for (int side = 0; side < 2; side++) {
            double *out = side ? back : moved;
            xp[k] = x[k] + (side ? -step : step);
            h += side ? x[k] - xp[k] : xp[k] - x[k];
            joint_map(m, xp, thk, 1);
            joint_map(m, xp + n, dthk, 0);
            if (k < n) frames(m, thk, Fk, own);            /* the others' do not move */
            forward_pass(m, Fk, dthk, ddth, vk, ak, fk, mask);
            moved_forces(m, mask, F, Fk, fk, acc, tau0, d, has, tau);
            memcpy(pas, pas0, sizeof(double) * nm);
            for (int j = 0; j < nm; j++)
                if (m->A[j * n + c] != 0.0) pas[j] = passive_of(m, j, thk[j], dthk[j]);
            for (int r = 0; r < n; r++) {
                double s = 0.0;
                if (m->mode == 0) s = tau[r] - pas[r];
                else for (int j = 0; j < nm; j++) s += m->A[j * n + r] * (tau[j] - pas[j]);
                out[r] = s;
            }
        }
        for (int r = 0; r < n; r++) J[(n + r) * n2 + k] = -(moved[r] - back[r]) / h;
        xp[k] = x[k];
        for (int i = 0; i < nb; i++)                       /* back to the base state */
            if (mask[i]) {
                Fk[i] = F[i];
                memcpy(vk + 6 * i, v + 6 * i, sizeof(double) * 6);
                memcpy(ak + 6 * i, a + 6 * i, sizeof(double) * 6);
                memcpy(fk + 6 * i, f + 6 * i, sizeof(double) * 6);
            }
    }
    for (int k = 0; k < n2 && !code; k++) {
        for (int r = 0; r < n; r++) col[r] = J[(n + r) * n2 + k];
        if (m->mode == 0) tree_solve(M, lam, col, n);
        else cholesky_solve(M, col, n);
        for (int r = 0; r < n; r++) J[(n + r) * n2 + k] = col[r];
    }
    free(F); free(mask); free(w);
    if (code) return code;
    return finite_all(J, n2 * n2) ? 0 : 2;
}

#define PY_SSIZE_T_CLEAN
#include <Python.h>

static int buffer(PyObject *o, Py_buffer *b, const char *format, Py_ssize_t size,
                  Py_ssize_t items, int writable) {
    if (PyObject_GetBuffer(o, b, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0)) < 0)
        return -1;
    if (b->itemsize != size || (b->format && strcmp(b->format, format) != 0)
        || (items >= 0 && b->len != items * size)) {
        PyBuffer_Release(b);
        PyErr_SetString(PyExc_TypeError, "expected a contiguous array of the right type and size");
        return -1;
    }
    return 0;
}

/* the model's tables (args[0] ints, args[1] doubles), checked against their sizes */
static int tables(PyObject *const *args, Py_buffer *bi, Py_buffer *bd, Model *m) {
    if (buffer(args[0], bi, "i", sizeof(int), -1, 0) < 0) return -1;
    const int *I = (const int *)bi->buf;
    Py_ssize_t ni = bi->len / (Py_ssize_t)sizeof(int);
    if (ni < 4 || I[0] < 1 || I[1] < 1 || I[2] < 1 || I[3] < 0 || I[3] > 2
        || (size_t)ni != ints_needed(I[0])) {
        PyBuffer_Release(bi);
        PyErr_SetString(PyExc_ValueError, "malformed integer table");
        return -1;
    }
    for (int i = 0; i < I[0]; i++) {
        int p = I[4 + 3 * i], k = I[5 + 3 * i], j = I[6 + 3 * i];
        if (p < -1 || p >= i || k < 0 || k > 2 || j < -1 || j >= I[2] || ((k == 0) != (j < 0))) {
            PyBuffer_Release(bi);
            PyErr_SetString(PyExc_ValueError, "malformed body table");
            return -1;
        }
    }
    if (buffer(args[1], bd, "d", sizeof(double),
               (Py_ssize_t)doubles_needed(I[0], I[1], I[2], I[3]), 0) < 0) {
        PyBuffer_Release(bi);
        return -1;
    }
    model_of(I, (const double *)bd->buf, m);
    return 0;
}

/* out = [dq, ddq] */
static int rhs(const Model *m, const double *x, const double *e, double *out) {
    memcpy(out, x + m->n, sizeof(double) * m->n);
    return accelerations(m, x, e, out + m->n);
}

typedef int (*state_kernel)(const Model *, const double *, const double *, double *);

/* f(ints, doubles, x, e, out) for a kernel of the state x (2N) and the joint
   efforts e (NM) writing 2N values, or 2N x 2N when square */
static PyObject *state_call(PyObject *const *args, Py_ssize_t nargs, state_kernel f, int square) {
    if (nargs != 5) { PyErr_SetString(PyExc_TypeError, "expected (ints, doubles, x, e, out)"); return NULL; }
    Py_buffer bi, bd, bx, be, bo;
    Model m;
    if (tables(args, &bi, &bd, &m) < 0) return NULL;
    int code = -1;
    if (buffer(args[2], &bx, "d", 8, 2 * m.n, 0) == 0) {
        if (buffer(args[3], &be, "d", 8, m.nm, 0) == 0) {
            if (buffer(args[4], &bo, "d", 8, 2 * m.n * (square ? 2 * m.n : 1), 1) == 0) {
                code = f(&m, (const double *)bx.buf, (const double *)be.buf, (double *)bo.buf);
                PyBuffer_Release(&bo);
            }
            PyBuffer_Release(&be);
        }
        PyBuffer_Release(&bx);
    }
    PyBuffer_Release(&bi); PyBuffer_Release(&bd);
    return code < 0 ? NULL : PyLong_FromLong(code);
}

/* rhs(ints, doubles, x, e, out): out = [dq, ddq] -> code */
static PyObject *py_rhs(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return state_call(args, nargs, rhs, 0);
}

/* jac(ints, doubles, x, e, J): J (2N x 2N) -> code */
static PyObject *py_jac(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return state_call(args, nargs, jacobian, 1);
}

/* inverse(ints, doubles, count, x, w, out): out[k] = M w[k] - F at x[k] (no actuators) */
static PyObject *py_inverse(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 6) { PyErr_SetString(PyExc_TypeError, "expected (ints, doubles, count, x, w, out)"); return NULL; }
    Py_buffer bi, bd, bx, bw, bo;
    Model m;
    Py_ssize_t count = PyLong_AsSsize_t(args[2]);
    if (count < 0) { if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "count < 0"); return NULL; }
    if (tables(args, &bi, &bd, &m) < 0) return NULL;
    int code = -1;
    if (buffer(args[3], &bx, "d", 8, 2 * m.n * count, 0) == 0) {
        if (buffer(args[4], &bw, "d", 8, m.n * count, 0) == 0) {
            if (buffer(args[5], &bo, "d", 8, m.n * count, 1) == 0) {
                const double *x = (const double *)bx.buf, *w = (const double *)bw.buf;
                double *o = (double *)bo.buf;
                code = 0;
                for (Py_ssize_t k = 0; k < count && !code; k++)
                    code = inverse(&m, x + 2 * m.n * k, x + 2 * m.n * k + m.n, w + m.n * k, o + m.n * k);
                PyBuffer_Release(&bo);
            }
            PyBuffer_Release(&bw);
        }
        PyBuffer_Release(&bx);
    }
    PyBuffer_Release(&bi); PyBuffer_Release(&bd);
    return code < 0 ? NULL : PyLong_FromLong(code);
}

/* mass(ints, doubles, q, out): out = M(q) (N x N) by composite rigid bodies */
static PyObject *py_mass(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 4) { PyErr_SetString(PyExc_TypeError, "expected (ints, doubles, q, out)"); return NULL; }
    Py_buffer bi, bd, bq, bo;
    Model m;
    if (tables(args, &bi, &bd, &m) < 0) return NULL;
    int code = -1;
    if (buffer(args[2], &bq, "d", 8, m.n, 0) == 0) {
        if (buffer(args[3], &bo, "d", 8, m.n * m.n, 1) == 0) {
            Frame *F = malloc(sizeof(Frame) * m.nb);
            double *th = malloc(sizeof(double) * (m.nm + m.nm * m.nm + m.nm * m.n));
            code = 1;
            if (F && th) {
                joint_map(&m, (const double *)bq.buf, th, 1);
                frames(&m, th, F, NULL);
                crba_joint(&m, F, th + m.nm);
                mass(&m, th + m.nm, (double *)bo.buf, th + m.nm + m.nm * m.nm);
                code = 0;
            }
            free(F); free(th);
            PyBuffer_Release(&bo);
        }
        PyBuffer_Release(&bq);
    }
    PyBuffer_Release(&bi); PyBuffer_Release(&bd);
    return code < 0 ? NULL : PyLong_FromLong(code);
}

static PyMethodDef methods[] = {
    {"rhs", (PyCFunction)(void (*)(void))py_rhs, METH_FASTCALL,
     "rhs(ints, doubles, x, e, out) -> 0 ok, 1 singular M, 2 non-finite"},
    {"jac", (PyCFunction)(void (*)(void))py_jac, METH_FASTCALL,
     "jac(ints, doubles, x, e, J) -> code"},
    {"inverse", (PyCFunction)(void (*)(void))py_inverse, METH_FASTCALL,
     "inverse(ints, doubles, count, x, w, out) -> code"},
    {"mass", (PyCFunction)(void (*)(void))py_mass, METH_FASTCALL,
     "mass(ints, doubles, q, out) -> code"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, MODULE_NAME, NULL, -1, methods};

PyMODINIT_FUNC INIT_FUNCTION(void) { return PyModule_Create(&module); }
