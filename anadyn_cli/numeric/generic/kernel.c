/* anadyn_generic: the recursions over a robot's numeric tables, compiled once per
   installation (not per robot); see anadyn_cli/numeric/generic/__init__.py.

   Tables (built by generic.tables.pack):
     ints  I = [NB, N, NM, MODE, NQ, then per body: parent (-1: the world), kind
               (0 fixed, 1 revolute, 2 prismatic, 3 spherical), joint (its first
               moving index, -1; a spherical joint has three, its angular velocity's
               x, y, z in body axes), coordinate and speed (a spherical joint's
               quaternion (qw, qx, qy, qz) in q and angular velocity in u, else -1)]
     doubles D = [gravity (3), per body BODY doubles: C^T (9, row-major: parent
               axes -> joint axes), origin (3), axis (3), mass, h = m c (3),
               I_O (9, about the origin); per moving joint PASSIVE doubles:
               damping, friction, friction_velocity, stiffness, rest; the joint
               map theta = A q + c: A (NM x N), c (NM); with MODE 1 A^-1 (N x NM)]
   MODE: 0 A = 1 (theta = q + c), 1 A square and invertible, 2 otherwise (the
   accelerations by CRBA and a dense Cholesky factorization of M = A^T H A).

   State x = [q (NQ), u (N)]: u = dq for every coordinate but a quaternion's; the
   NP = N - 3 (NQ - N) first coordinates have the first NP speeds as rates, each
   spherical joint's quaternion dq = 1/2 q (x) (0, w).  A spherical joint's rows of
   A are unit rows on its speeds (dtheta = w), its theta zero: its quaternion turns
   it, R(q) written for any non-zero q (divided by |q|^2).

   Spatial vectors (angular, linear) at the body origin in body axes; gravity as
   the base's acceleration a_0 = (0, -g).  All functions return 0, or 1 when M is
   not positive definite, 2 when a result is not finite. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BODY 28
#define PASSIVE 5
#define HEAD 5
#define STRIDE 5
#define SPHERICAL 3

typedef struct {
    int nb, n, nm, mode, nq, np;
    const int *bodies;                     /* STRIDE per body, from ints + HEAD */
    const double *g, *body, *passive, *A, *c, *Ainv;
} Model;

typedef struct {                           /* per body, at one q */
    double E[9], r[3];
} Frame;

static void model_of(const int *I, const double *D, Model *m) {
    m->nb = I[0]; m->n = I[1]; m->nm = I[2]; m->mode = I[3]; m->nq = I[4];
    m->np = m->n - 3 * (m->nq - m->n);
    m->bodies = I + HEAD;
    m->g = D;
    m->body = D + 3;
    m->passive = m->body + BODY * m->nb;
    m->A = m->passive + PASSIVE * m->nm;
    m->c = m->A + m->nm * m->n;
    m->Ainv = m->c + m->nm;
}

#define PARENT(m, i) ((m)->bodies[STRIDE * (i)])
#define KIND(m, i) ((m)->bodies[STRIDE * (i) + 1])
#define JOINT(m, i) ((m)->bodies[STRIDE * (i) + 2])
#define COORDINATE(m, i) ((m)->bodies[STRIDE * (i) + 3])
#define SPEED(m, i) ((m)->bodies[STRIDE * (i) + 4])

static size_t ints_needed(int nb) { return HEAD + STRIDE * (size_t)nb; }

static size_t doubles_needed(int nb, int n, int nm, int mode) {
    return 3 + (size_t)BODY * nb + (size_t)PASSIVE * nm + (size_t)nm * n + nm
           + (mode == 1 ? (size_t)n * nm : 0);
}

/* the number of speeds of a joint kind */
static int speeds_of(int kind) { return kind == SPHERICAL ? 3 : kind > 0; }

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

/* theta of the coordinates q (NQ): A q + c, a spherical joint's zero */
static void positions(const Model *m, const double *q, double *th) {
    joint_map(m, q, th, 1);
    for (int i = 0; i < m->nb; i++)
        if (KIND(m, i) == SPHERICAL) {
            int j = JOINT(m, i);
            th[j] = th[j + 1] = th[j + 2] = 0.0;
        }
}

/* dq = W(q) u: the speeds for the first NP coordinates, 1/2 q (x) (0, w) for each
   spherical joint's quaternion (x = [q, u]) */
static void rates(const Model *m, const double *x, double *dq) {
    const double *u = x + m->nq;
    memcpy(dq, u, sizeof(double) * m->np);
    for (int i = 0; i < m->nb; i++) {
        if (KIND(m, i) != SPHERICAL) continue;
        const double *p = x + COORDINATE(m, i), *s = u + SPEED(m, i);
        double w = p[0], qx = p[1], qy = p[2], qz = p[3], a = s[0], b = s[1], c = s[2];
        double *o = dq + COORDINATE(m, i);
        o[0] = -(qx * a + qy * b + qz * c) * 0.5;
        o[1] = (w * a + qy * c - qz * b) * 0.5;
        o[2] = (w * b + qz * a - qx * c) * 0.5;
        o[3] = (w * c + qx * b - qy * a) * 0.5;
    }
}

/* the coordinates' rows of the state Jacobian J (NQ + N columns): d(W(q) u)/dx */
static void rate_rows(const Model *m, const double *x, double *J) {
    int nq = m->nq, ns = nq + m->n;
    for (int k = 0; k < m->np; k++) J[k * ns + nq + k] = 1.0;
    for (int i = 0; i < m->nb; i++) {
        if (KIND(m, i) != SPHERICAL) continue;
        int c = COORDINATE(m, i), s = nq + SPEED(m, i);
        const double *p = x + c, *w = x + s;
        const double dp[4][4] = {{0, -w[0], -w[1], -w[2]}, {w[0], 0, w[2], -w[1]},
                                 {w[1], -w[2], 0, w[0]}, {w[2], w[1], -w[0], 0}};
        const double dw[4][3] = {{-p[1], -p[2], -p[3]}, {p[0], -p[3], p[2]},
                                 {p[3], p[0], -p[1]}, {-p[2], p[1], p[0]}};
        for (int r = 0; r < 4; r++) {
            for (int k = 0; k < 4; k++) J[(c + r) * ns + c + k] = 0.5 * dp[r][k];
            for (int k = 0; k < 3; k++) J[(c + r) * ns + s + k] = 0.5 * dw[r][k];
        }
    }
}

/* E = Rot(a, theta)^T C^T (revolute), R(q)^T C^T (spherical, q its quaternion in
   the coordinates q) or C^T; r = origin (+ C a theta, prismatic), for every body
   (only: those marked) */
static void frames(const Model *m, const double *q, const double *theta, Frame *F,
                   const int *only) {
    for (int i = 0; i < m->nb; i++) {
        if (only && !only[i]) continue;
        const double *b = m->body + BODY * i, *CT = b, *o = b + 9, *a = b + 12;
        Frame *f = F + i;
        double RT[9];
        int turned = 1;
        memcpy(f->r, o, sizeof(double) * 3);
        if (KIND(m, i) == 1) {
            double th = theta[JOINT(m, i)], cs = cos(th), sn = sin(th);
            for (int r = 0; r < 3; r++)
                for (int k = 0; k < 3; k++)
                    RT[3 * r + k] = (r == k ? cs : 0.0) + (1.0 - cs) * a[r] * a[k];
            RT[1] += sn * a[2]; RT[2] -= sn * a[1];      /* - s [a]x */
            RT[3] -= sn * a[2]; RT[5] += sn * a[0];
            RT[6] += sn * a[1]; RT[7] -= sn * a[0];
        } else if (KIND(m, i) == SPHERICAL) {            /* RT = (|p|^2 R(p))^T / |p|^2 */
            const double *p = q + COORDINATE(m, i);
            double w = p[0], x = p[1], y = p[2], z = p[3];
            double s = 1.0 / (w * w + x * x + y * y + z * z);
            RT[0] = (w * w + x * x - y * y - z * z) * s;
            RT[4] = (w * w - x * x + y * y - z * z) * s;
            RT[8] = (w * w - x * x - y * y + z * z) * s;
            RT[3] = 2 * (x * y - w * z) * s; RT[1] = 2 * (x * y + w * z) * s;
            RT[6] = 2 * (x * z + w * y) * s; RT[2] = 2 * (x * z - w * y) * s;
            RT[7] = 2 * (y * z - w * x) * s; RT[5] = 2 * (y * z + w * x) * s;
        } else {
            turned = 0;
            memcpy(f->E, CT, sizeof(double) * 9);
            if (KIND(m, i) == 2) {
                double th = theta[JOINT(m, i)];
                for (int r = 0; r < 3; r++)          /* C a = (C^T)^T a */
                    f->r[r] += th * (CT[r] * a[0] + CT[3 + r] * a[1] + CT[6 + r] * a[2]);
            }
        }
        if (turned)
            for (int r = 0; r < 3; r++)
                for (int k = 0; k < 3; k++)
                    f->E[3 * r + k] = RT[3 * r] * CT[k] + RT[3 * r + 1] * CT[3 + k]
                                      + RT[3 * r + 2] * CT[6 + k];
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

/* the motion subspace of body i: its columns (6 doubles each) in S (room for 3),
   their number returned (0 fixed, 1 revolute or prismatic, 3 spherical) */
static int subspace(const Model *m, int i, double *S) {
    const double *a = m->body + BODY * i + 12;
    int kind = KIND(m, i), d = speeds_of(kind);
    memset(S, 0, sizeof(double) * 6 * d);
    if (kind == 1) memcpy(S, a, sizeof(double) * 3);
    else if (kind == 2) memcpy(S + 3, a, sizeof(double) * 3);
    else if (kind == SPHERICAL) S[0] = S[7] = S[14] = 1.0;
    return d;
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
        double S[18], t[6];
        int p = PARENT(m, i), j = JOINT(m, i), d = subspace(m, i, S);
        if (p < 0) {
            double w0[6] = {0, 0, 0, 0, 0, 0}, a0[6] = {0, 0, 0, -m->g[0], -m->g[1], -m->g[2]};
            motion_in(F + i, w0, v + 6 * i);
            if (a) motion_in(F + i, a0, a + 6 * i);
        } else {
            motion_in(F + i, v + 6 * p, v + 6 * i);
            if (a) motion_in(F + i, a + 6 * p, a + 6 * i);
        }
        if (j >= 0) {
            double sd[6] = {0, 0, 0, 0, 0, 0};
            for (int c = 0; c < d; c++)
                for (int k = 0; k < 6; k++) sd[k] += S[6 * c + k] * dtheta[j + c];
            if (a) {
                cross_motion(v + 6 * i, sd, t);          /* v_before x S dtheta */
                for (int k = 0; k < 6; k++) a[6 * i + k] += t[k];
                for (int c = 0; c < d; c++)
                    for (int k = 0; k < 6; k++) a[6 * i + k] += S[6 * c + k] * ddtheta[j + c];
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
            double S[18];
            int d = subspace(m, i, S);
            for (int c = 0; c < d; c++) tau[j + c] = dot6(S + 6 * c, f + 6 * i);
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

/* ID = A^T (tau_rigid(q, u, du) - tau_passive) = M du - F (q: NQ, dq, ddq: N) */
static int inverse(const Model *m, const double *q, const double *dq, const double *ddq,
                   double *out) {
    int nb = m->nb, nm = m->nm;
    Frame *F = malloc(sizeof(Frame) * nb);
    double *w = malloc(sizeof(double) * (18 * nb + 5 * nm + 1));
    if (!F || !w) { free(F); free(w); return 1; }
    double *v = w, *a = v + 6 * nb, *f = a + 6 * nb, *th = f + 6 * nb, *dth = th + nm,
           *ddth = dth + nm, *tau = ddth + nm, *pas = tau + nm;
    positions(m, q, th);
    joint_map(m, dq, dth, 0);
    joint_map(m, ddq, ddth, 0);
    frames(m, q, th, F, NULL);
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
            double S[18], Sb[18], f[6], t[6];
            int d = subspace(m, i, S);
            for (int c = 0; c < d; c++) {
                mv6(Ic + 36 * i, S + 6 * c, f);
                for (int e = 0; e < d; e++) H[(j + e) * nm + j + c] = dot6(S + 6 * e, f);
                for (int b = i; PARENT(m, b) >= 0;) {
                    force_out(F + b, f, t);
                    memcpy(f, t, sizeof t);
                    b = PARENT(m, b);
                    int jb = JOINT(m, b), db = jb >= 0 ? subspace(m, b, Sb) : 0;
                    for (int e = 0; e < db; e++)
                        H[(j + c) * nm + jb + e] = H[(jb + e) * nm + j + c] = dot6(Sb + 6 * e, f);
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

/* b -= l a for rows a, b of w doubles (nothing when l = 0: a factor's zeros) */
static void row_update(double *b, double l, const double *a, int w) {
    if (l == 0.0) return;
    for (int c = 0; c < w; c++) b[c] -= l * a[c];
}

/* B = (L^T L)^-1 B in place (``tree_factor``), B: n rows of w right-hand sides,
   every row operation on all of them at once */
static void tree_solve(const double *L, const int *lam, double *B, int n, int w) {
    for (int k = n - 1; k >= 0; k--) {
        for (int c = 0; c < w; c++) B[k * w + c] /= L[k * n + k];
        for (int i = lam[k]; i >= 0; i = lam[i]) row_update(B + i * w, L[k * n + i], B + k * w, w);
    }
    for (int k = 0; k < n; k++) {
        for (int i = lam[k]; i >= 0; i = lam[i]) row_update(B + k * w, L[k * n + i], B + i * w, w);
        for (int c = 0; c < w; c++) B[k * w + c] /= L[k * n + k];
    }
}

/* B = (L L^T)^-1 B in place, B: n rows of w right-hand sides */
static void cholesky_solve(const double *M, double *B, int n, int w) {
    for (int i = 0; i < n; i++) {
        for (int k = 0; k < i; k++) row_update(B + i * w, M[i * n + k], B + k * w, w);
        for (int c = 0; c < w; c++) B[i * w + c] /= M[i * n + i];
    }
    for (int i = n - 1; i >= 0; i--) {
        for (int k = i + 1; k < n; k++) row_update(B + i * w, M[k * n + i], B + k * w, w);
        for (int c = 0; c < w; c++) B[i * w + c] /= M[i * n + i];
    }
}

/* Dinv = D^-1 for a symmetric d x d D (d <= 3) by its Cholesky factor; 1 if D is
   not positive definite */
static int small_inverse(const double *D, int d, double *Dinv) {
    double L[9] = {0}, Li[9] = {0};
    if (d == 1) {
        if (!(D[0] > 0.0)) return 1;
        Dinv[0] = 1.0 / D[0];
        return 0;
    }
    memcpy(L, D, sizeof(double) * d * d);
    if (cholesky(L, d)) return 1;
    for (int c = 0; c < d; c++) {                      /* Li = L^-1, column c */
        for (int r = c; r < d; r++) {
            double s = r == c ? 1.0 : 0.0;
            for (int k = c; k < r; k++) s -= L[r * d + k] * Li[k * d + c];
            Li[r * d + c] = s / L[r * d + r];
        }
    }
    for (int r = 0; r < d; r++)                        /* Dinv = Li^T Li */
        for (int c = 0; c < d; c++) {
            double s = 0.0;
            for (int k = r > c ? r : c; k < d; k++) s += Li[k * d + r] * Li[k * d + c];
            Dinv[r * d + c] = s;
        }
    return 0;
}

/* ddtheta by the articulated-body algorithm for the joint forces tau (NM): per
   joint with d speeds (columns S), U = I^A S, D = S^T U (d x d), u = tau - S^T p^A */
static int aba_joint(const Model *m, const Frame *F, const double *dth, const double *tau,
                     double *ddth) {
    int nb = m->nb;
    double *w = malloc(sizeof(double) * (6 * nb * 4 + 18 * nb + 36 * nb + 12 * nb));
    if (!w) return 1;
    double *v = w, *c = v + 6 * nb, *pA = c + 6 * nb, *a = pA + 6 * nb, *U = a + 6 * nb,
           *IA = U + 18 * nb, *Dinv = IA + 36 * nb, *u = Dinv + 9 * nb;
    for (int i = 0; i < nb; i++) {
        double S[18], Iv[6], sd[6] = {0, 0, 0, 0, 0, 0};
        int p = PARENT(m, i), j = JOINT(m, i), d = subspace(m, i, S);
        if (p < 0) { double z[6] = {0}; motion_in(F + i, z, v + 6 * i); }
        else motion_in(F + i, v + 6 * p, v + 6 * i);
        memset(c + 6 * i, 0, sizeof(double) * 6);
        if (j >= 0) {
            for (int e = 0; e < d; e++)
                for (int k = 0; k < 6; k++) sd[k] += S[6 * e + k] * dth[j + e];
            cross_motion(v + 6 * i, sd, c + 6 * i);
            for (int k = 0; k < 6; k++) v[6 * i + k] += sd[k];
        }
        inertia(m->body + BODY * i, IA + 36 * i);
        mv6(IA + 36 * i, v + 6 * i, Iv);
        cross_force(v + 6 * i, Iv, pA + 6 * i);
    }
    for (int i = nb - 1; i >= 0; i--) {
        int p = PARENT(m, i), j = JOINT(m, i), d = 0;
        double *I6 = IA + 36 * i, Ia[36], pa[6], t[6], S[18], *Ui = U + 18 * i,
               *Di = Dinv + 9 * i, *ui = u + 3 * i, Du[3] = {0, 0, 0};
        memcpy(Ia, I6, sizeof Ia);
        if (j >= 0) {
            double D[9];
            d = subspace(m, i, S);
            for (int e = 0; e < d; e++) {
                mv6(I6, S + 6 * e, Ui + 6 * e);
                ui[e] = tau[j + e] - dot6(S + 6 * e, pA + 6 * i);
            }
            for (int r = 0; r < d; r++)
                for (int e = 0; e < d; e++) D[r * d + e] = dot6(S + 6 * r, Ui + 6 * e);
            if (small_inverse(D, d, Di)) { free(w); return 1; }
            for (int r = 0; r < d; r++)
                for (int e = 0; e < d; e++) Du[r] += Di[r * d + e] * ui[e];
            for (int r = 0; r < d; r++)                 /* Ia -= U Dinv U^T */
                for (int e = 0; e < d; e++) {
                    double g = Di[r * d + e];
                    for (int x = 0; x < 6; x++)
                        for (int k = 0; k < 6; k++) Ia[6 * x + k] -= Ui[6 * r + x] * g * Ui[6 * e + k];
                }
        }
        if (p < 0) continue;
        mv6(Ia, c + 6 * i, pa);
        for (int k = 0; k < 6; k++) {
            pa[k] += pA[6 * i + k];
            for (int e = 0; e < d; e++) pa[k] += Ui[6 * e + k] * Du[e];
        }
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
            double S[18], r[3];
            int d = subspace(m, i, S);
            const double *Ui = U + 18 * i, *Di = Dinv + 9 * i, *ui = u + 3 * i;
            for (int e = 0; e < d; e++) r[e] = ui[e] - dot6(Ui + 6 * e, a + 6 * i);
            for (int e = 0; e < d; e++) {
                double s = 0.0;
                for (int k = 0; k < d; k++) s += Di[e * d + k] * r[k];
                ddth[j + e] = s;
                for (int k = 0; k < 6; k++) a[6 * i + k] += S[6 * e + k] * s;
            }
        }
    }
    free(w);
    return 0;
}

static int finite_all(const double *v, int k) {
    for (int i = 0; i < k; i++) if (!isfinite(v[i])) return 0;
    return 1;
}

/* du solving M du = A^T (e + tau_passive - bias) at x = [q, u]: e the joint
   efforts of the actuators (NM); by ABA (MODE 0, 1) or CRBA + Cholesky (MODE 2) */
static int accelerations(const Model *m, const double *x, const double *e, double *ddq) {
    int n = m->n, nm = m->nm, nb = m->nb, code = 0;
    Frame *F = malloc(sizeof(Frame) * nb);
    double *w = malloc(sizeof(double) * (5 * nm + nm * nm + nm * n + n * n + 18 * nb + 1));
    if (!F || !w) { free(F); free(w); return 1; }
    double *th = w, *dth = th + nm, *tau = dth + nm, *ddth = tau + nm, *bias = ddth + nm,
           *H = bias + nm, *M = H + nm * nm, *HA = M + n * n, *scratch = HA + nm * n;
    positions(m, x, th);
    joint_map(m, x + m->nq, dth, 0);
    frames(m, x, th, F, NULL);
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
        if (!code) cholesky_solve(M, ddq, n, 1);
    }
    free(F); free(w);
    if (code) return code;
    return finite_all(ddq, n) ? 0 : 2;
}

/* whether the joint of body i moves with the state entry k of x = [q, u] */
static int moves_with(const Model *m, int i, int k) {
    int j = JOINT(m, i);
    if (j < 0) return 0;
    if (KIND(m, i) == SPHERICAL) {
        int first = k < m->nq ? COORDINATE(m, i) : m->nq + SPEED(m, i);
        return k >= first && k < first + (k < m->nq ? 4 : 3);
    }
    if (k >= m->np && k < m->nq) return 0;              /* a quaternion's coordinate */
    return m->A[j * m->n + (k < m->nq ? k : k - m->nq)] != 0.0;
}

/* o = I v for the spatial inertia of body b about its origin (``inertia``):
   (I_O w + h x v, m v - h x w), v = (w, v) */
static void inertia_times(const double *b, const double *v, double *o) {
    const double m = b[15], *h = b + 16;
    double t[3];
    mv3(b + 19, v, o);
    cross3(h, v + 3, t);
    for (int k = 0; k < 3; k++) o[k] += t[k];
    cross3(h, v, t);
    for (int k = 0; k < 3; k++) o[3 + k] = m * v[3 + k] - t[k];
}

/* the derivative dF (dE, dr) of body i's frame F (``frames``) with respect to the
   coordinate q_k that moves its joint (x = [q, u], theta the joints' displacements):
   revolute dE = dRot(a, theta)^T/dtheta C^T A_jk, prismatic dr = C a A_jk;
   spherical, q_k its quaternion p's component c: R(p)^T = N(p)/|p|^2, N(p) = Q(p, p)
   for a symmetric bilinear Q, so dE = 2 (Q(p, e_c) C^T - p_c E)/|p|^2 */
static void frame_derivative(const Model *m, int i, const double *x, const double *theta,
                             int k, const Frame *F, Frame *dF) {
    const double *b = m->body + BODY * i, *CT = b, *a = b + 12;
    double dRT[9];
    memset(dF->r, 0, sizeof(double) * 3);
    if (KIND(m, i) == SPHERICAL) {
        const double *p = x + COORDINATE(m, i);
        double w = p[0], qx = p[1], qy = p[2], qz = p[3], e[4] = {0, 0, 0, 0};
        double s = 2.0 / (w * w + qx * qx + qy * qy + qz * qz), pc = p[k - COORDINATE(m, i)];
        e[k - COORDINATE(m, i)] = 1.0;                   /* dRT = Q(p, e_c) */
        dRT[0] = w * e[0] + qx * e[1] - qy * e[2] - qz * e[3];
        dRT[4] = w * e[0] - qx * e[1] + qy * e[2] - qz * e[3];
        dRT[8] = w * e[0] - qx * e[1] - qy * e[2] + qz * e[3];
        dRT[3] = qx * e[2] + qy * e[1] - w * e[3] - qz * e[0];
        dRT[1] = qx * e[2] + qy * e[1] + w * e[3] + qz * e[0];
        dRT[6] = qx * e[3] + qz * e[1] + w * e[2] + qy * e[0];
        dRT[2] = qx * e[3] + qz * e[1] - w * e[2] - qy * e[0];
        dRT[7] = qy * e[3] + qz * e[2] - w * e[1] - qx * e[0];
        dRT[5] = qy * e[3] + qz * e[2] + w * e[1] + qx * e[0];
        mm3(dRT, CT, dF->E);
        for (int r = 0; r < 9; r++) dF->E[r] = s * (dF->E[r] - pc * F->E[r]);
        return;
    }
    double rate = m->A[JOINT(m, i) * m->n + k];
    if (KIND(m, i) == 2) {
        memset(dF->E, 0, sizeof(double) * 9);
        for (int r = 0; r < 3; r++)                      /* C a = (C^T)^T a */
            dF->r[r] = rate * (CT[r] * a[0] + CT[3 + r] * a[1] + CT[6 + r] * a[2]);
        return;
    }
    double cs = cos(theta[JOINT(m, i)]) * rate, sn = sin(theta[JOINT(m, i)]) * rate;
    for (int r = 0; r < 3; r++)             /* d/dtheta (c 1 + (1 - c) a a^T - s [a]x) */
        for (int c = 0; c < 3; c++) dRT[3 * r + c] = (r == c ? -sn : 0.0) + sn * a[r] * a[c];
    dRT[1] += cs * a[2]; dRT[2] -= cs * a[1];
    dRT[3] -= cs * a[2]; dRT[5] += cs * a[0];
    dRT[6] += cs * a[1]; dRT[7] -= cs * a[0];
    mm3(dRT, CT, dF->E);
}

/* the derivative of motion_in(F, p), p = (w, v), with p's derivative dp (NULL: 0)
   and the frame's dF (NULL: fixed): motion_in(F, dp) plus (dE w, dE (v - r x w)
   - E (dr x w)) */
static void motion_derivative(const Frame *F, const Frame *dF, const double *p,
                              const double *dp, double *o) {
    double rw[3], d[3], t[3], u[3];
    if (dp) motion_in(F, dp, o);
    else memset(o, 0, sizeof(double) * 6);
    if (!dF) return;
    cross3(F->r, p, rw);
    for (int k = 0; k < 3; k++) d[k] = p[3 + k] - rw[k];
    mv3(dF->E, p, t);
    for (int k = 0; k < 3; k++) o[k] += t[k];
    cross3(dF->r, p, rw);
    mv3(F->E, rw, u);
    mv3(dF->E, d, t);
    for (int k = 0; k < 3; k++) o[3 + k] += t[k] - u[k];
}

/* the derivative of force_out(F, c) with c's derivative dc and the frame's dF
   (NULL: fixed): force_out(F, dc) plus (dE^T n + dr x E^T f + r x dE^T f, dE^T f) */
static void force_derivative(const Frame *F, const Frame *dF, const double *c,
                             const double *dc, double *o) {
    double t[3], u[3];
    force_out(F, dc, o);
    if (!dF) return;
    mtv3(dF->E, c + 3, t);
    cross3(F->r, t, u);
    for (int k = 0; k < 3; k++) { o[3 + k] += t[k]; o[k] += u[k]; }
    mtv3(F->E, c + 3, t);
    cross3(dF->r, t, u);
    mtv3(dF->E, c, t);
    for (int k = 0; k < 3; k++) o[k] += u[k] + t[k];
}

/* the derivative of passive_of(m, j, theta, dtheta) for the derivatives t_theta
   of theta and t_dtheta of dtheta */
static double passive_derivative(const Model *m, int j, double dtheta, double t_theta,
                                 double t_dtheta) {
    const double *p = m->passive + PASSIVE * j;
    double v = 0.0;
    if (p[0] != 0.0) v -= p[0] * t_dtheta;
    if (p[1] != 0.0) {
        double th = tanh(dtheta / p[2]);
        v -= p[1] * (1.0 - th * th) / p[2] * t_dtheta;
    }
    if (p[3] != 0.0) v -= p[3] * t_theta;
    return v;
}

/* J = [[R, 0 ...], [M^-1 K]] ((NQ + N) x (NQ + N)) at fixed joint efforts e: R =
   d(W(q) u)/dx (rate_rows), K = -dID/dx at fixed du, exact: column by column, the
   recursive Newton-Euler algorithm differentiated in forward mode (tangent-linear)
   along the state entry x_k, on the bodies x_k moves only: the frames of the bodies
   whose joint moves with x_k (frame_derivative), the velocities, accelerations and
   body forces of their subtrees (forward), the forces' change carried up to the
   root (backward), the joints' springs, dampers and friction (passive_derivative);
   then solved with the factor of M (composite rigid bodies; with A = 1 the tree's
   LTL factor, else a dense Cholesky factor) */
static int jacobian(const Model *m, const double *x, const double *e, double *J) {
    int n = m->n, nq = m->nq, nm = m->nm, nb = m->nb, ns = nq + n, code;
    Frame *F = malloc(sizeof(Frame) * 2 * nb);
    int *mask = malloc(sizeof(int) * (3 * nb + nm));
    double *w = malloc(sizeof(double) * (n + 6 * nm + 48 * nb + nm * nm + nm * n + n * n));
    if (!F || !mask || !w) { free(F); free(mask); free(w); return 1; }
    Frame *dF = F + nb;
    int *has = mask + nb, *own = has + nb, *lam = own + nb;
    double *ddq = w, *th = ddq + n, *dth = th + nm, *ddth = dth + nm,
           *tth = ddth + nm, *tdth = tth + nm, *ttau = tdth + nm, *v = ttau + nm,
           *a = v + 6 * nb, *f = a + 6 * nb, *acc = f + 6 * nb, *Iv = acc + 6 * nb,
           *tv = Iv + 6 * nb, *ta = tv + 6 * nb, *tacc = ta + 6 * nb, *H = tacc + 6 * nb,
           *HA = H + nm * nm, *M = HA + nm * n;
    const double zero[6] = {0, 0, 0, 0, 0, 0},
                 a0[6] = {0, 0, 0, -m->g[0], -m->g[1], -m->g[2]};
    code = accelerations(m, x, e, ddq);
    if (!code) {
        positions(m, x, th);
        joint_map(m, x + nq, dth, 0);
        joint_map(m, ddq, ddth, 0);
        frames(m, x, th, F, NULL);
        forward_pass(m, F, dth, ddth, v, a, f, NULL);
        memcpy(acc, f, sizeof(double) * 6 * nb);
        backward_pass(m, F, acc, ttau);
        for (int i = 0; i < nb; i++) inertia_times(m->body + BODY * i, v + 6 * i, Iv + 6 * i);
        crba_joint(m, F, H);
        mass(m, H, M, HA);
        for (int i = 0; i < nb; i++) {      /* each speed's nearest moving ancestor */
            int j = JOINT(m, i), p = PARENT(m, i);
            while (p >= 0 && JOINT(m, p) < 0) p = PARENT(m, p);
            if (j < 0) continue;
            lam[j] = p < 0 ? -1 : JOINT(m, p) + speeds_of(KIND(m, p)) - 1;
            for (int c = 1; c < speeds_of(KIND(m, i)); c++) lam[j + c] = j + c - 1;
        }
        code = m->mode == 0 ? tree_factor(M, lam, n) : cholesky(M, n);
    }
    memset(J, 0, sizeof(double) * ns * ns);
    rate_rows(m, x, J);
    for (int k = 0; k < ns && !code; k++) {
        int speed = k >= nq, kc = speed ? k - nq : k;
        for (int i = 0; i < nb; i++) {
            int p = PARENT(m, i);
            own[i] = moves_with(m, i, k);
            mask[i] = own[i] || (p >= 0 && mask[p]);
            has[i] = 0;
        }
        memset(ttau, 0, sizeof(double) * nm);
        for (int i = 0; i < nb; i++) {         /* forward: the moved subtrees */
            if (!mask[i]) continue;
            int p = PARENT(m, i), j = JOINT(m, i), dof, turned = own[i] && !speed;
            double S[18], sd[6] = {0, 0, 0, 0, 0, 0}, tsd[6] = {0, 0, 0, 0, 0, 0}, vb[6],
                   tvb[6], t[6], Iw[6];
            dof = subspace(m, i, S);
            if (own[i]) {
                int sphere = KIND(m, i) == SPHERICAL;
                for (int c = 0; c < dof; c++) {
                    double r = sphere && !speed ? 0.0 : m->A[(j + c) * n + kc];
                    tdth[j + c] = speed ? r : 0.0;
                    tth[j + c] = speed || sphere ? 0.0 : r;
                    for (int l = 0; l < 6; l++) tsd[l] += S[6 * c + l] * tdth[j + c];
                }
                if (turned) frame_derivative(m, i, x, th, k, F + i, dF + i);
            }
            for (int c = 0; c < dof; c++)
                for (int l = 0; l < 6; l++) sd[l] += S[6 * c + l] * dth[j + c];
            const Frame *dFi = turned ? dF + i : NULL;
            int moving = p >= 0 && mask[p];
            motion_derivative(F + i, dFi, p < 0 ? zero : v + 6 * p, moving ? tv + 6 * p : NULL,
                              tvb);
            motion_derivative(F + i, dFi, p < 0 ? a0 : a + 6 * p, moving ? ta + 6 * p : NULL,
                              ta + 6 * i);
            for (int l = 0; l < 6; l++) vb[l] = v[6 * i + l] - sd[l];
            cross_motion(tvb, sd, t);                  /* d(v_before x S dtheta) */
            for (int l = 0; l < 6; l++) ta[6 * i + l] += t[l];
            cross_motion(vb, tsd, t);
            for (int l = 0; l < 6; l++) {
                ta[6 * i + l] += t[l];
                tv[6 * i + l] = tvb[l] + tsd[l];
            }
            inertia_times(m->body + BODY * i, ta + 6 * i, tacc + 6 * i);   /* d(I a + v x* I v) */
            cross_force(tv + 6 * i, Iv + 6 * i, t);
            for (int l = 0; l < 6; l++) tacc[6 * i + l] += t[l];
            inertia_times(m->body + BODY * i, tv + 6 * i, Iw);
            cross_force(v + 6 * i, Iw, t);
            for (int l = 0; l < 6; l++) tacc[6 * i + l] += t[l];
        }
        for (int i = nb - 1; i >= 0; i--) {    /* backward: up to the root */
            if (!mask[i] && !has[i]) continue;
            int p = PARENT(m, i), j = JOINT(m, i), dof;
            double S[18], t[6];
            dof = subspace(m, i, S);
            for (int c = 0; c < dof; c++) {
                ttau[j + c] = dot6(S + 6 * c, tacc + 6 * i);
                if (own[i])
                    ttau[j + c] -= passive_derivative(m, j + c, dth[j + c], tth[j + c],
                                                      tdth[j + c]);
            }
            if (p < 0) continue;
            force_derivative(F + i, own[i] && !speed ? dF + i : NULL, acc + 6 * i, tacc + 6 * i, t);
            if (!mask[p] && !has[p]) { memset(tacc + 6 * p, 0, sizeof(double) * 6); has[p] = 1; }
            for (int l = 0; l < 6; l++) tacc[6 * p + l] += t[l];
        }
        for (int j = 0; j < nm; j++) {        /* column k of K = -A^T dtau (J zero) */
            if (ttau[j] == 0.0) continue;
            if (m->mode == 0) J[(nq + j) * ns + k] = -ttau[j];
            else for (int r = 0; r < n; r++) J[(nq + r) * ns + k] -= m->A[j * n + r] * ttau[j];
        }
    }
    if (!code && m->mode == 0) tree_solve(M, lam, J + nq * ns, n, ns);    /* K's rows */
    else if (!code) cholesky_solve(M, J + nq * ns, n, ns);
    free(F); free(mask); free(w);
    if (code) return code;
    return finite_all(J, ns * ns) ? 0 : 2;
}

/* T = 1/2 sum_i v_i . I_i v_i (body velocities, spatial inertias about the body
   origins), V = -sum_i g . (m_i p_i + R_i h_i) + sum_j 1/2 stiffness_j (theta_j -
   rest_j)^2 (p_i, R_i: the body's origin and axes in the world) and the power
   the joints dissipate, P_d = sum_j dtheta_j (damping_j dtheta_j + friction_j
   tanh(dtheta_j / v_j)), at x = [q, u]: out = [T, V, P_d] */
static int energies(const Model *m, const double *x, double *out) {
    int nb = m->nb, nm = m->nm;
    Frame *F = malloc(sizeof(Frame) * nb);
    double *w = malloc(sizeof(double) * (2 * nm + 18 * nb));
    if (!F || !w) { free(F); free(w); return 1; }
    double *th = w, *dth = th + nm, *v = dth + nm, *R = v + 6 * nb, *p = R + 9 * nb;
    double T = 0.0, V = 0.0, P = 0.0;
    positions(m, x, th);
    joint_map(m, x + m->nq, dth, 0);
    frames(m, x, th, F, NULL);
    forward_pass(m, F, dth, NULL, v, NULL, NULL, NULL);
    for (int i = 0; i < nb; i++) {
        const double *b = m->body + BODY * i, *E = F[i].E, *r = F[i].r;
        double I6[36], Iv[6], *Ri = R + 9 * i, *pi = p + 3 * i, c[3];
        int par = PARENT(m, i);
        inertia(b, I6);
        mv6(I6, v + 6 * i, Iv);
        T += 0.5 * dot6(v + 6 * i, Iv);
        if (par < 0) {                        /* R_i = E^T, p_i = r */
            for (int a = 0; a < 3; a++)
                for (int k = 0; k < 3; k++) Ri[3 * a + k] = E[3 * k + a];
            memcpy(pi, r, sizeof(double) * 3);
        } else {                              /* R_i = R_p E^T, p_i = p_p + R_p r */
            const double *Rp = R + 9 * par, *pp = p + 3 * par;
            for (int a = 0; a < 3; a++) {
                pi[a] = pp[a];
                for (int k = 0; k < 3; k++) {
                    pi[a] += Rp[3 * a + k] * r[k];
                    Ri[3 * a + k] = Rp[3 * a] * E[3 * k] + Rp[3 * a + 1] * E[3 * k + 1]
                                    + Rp[3 * a + 2] * E[3 * k + 2];
                }
            }
        }
        mv3(Ri, b + 16, c);                   /* R_i h_i */
        for (int a = 0; a < 3; a++) V -= m->g[a] * (b[15] * pi[a] + c[a]);
    }
    for (int j = 0; j < nm; j++) {
        const double *s = m->passive + PASSIVE * j;
        double d = dth[j];
        if (s[0] != 0.0) P += s[0] * d * d;
        if (s[1] != 0.0) P += s[1] * d * tanh(d / s[2]);
        if (s[3] != 0.0) V += 0.5 * s[3] * (th[j] - s[4]) * (th[j] - s[4]);
    }
    out[0] = T; out[1] = V; out[2] = P;
    free(F); free(w);
    return finite_all(out, 3) ? 0 : 2;
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
    if (ni < HEAD || I[0] < 1 || I[1] < 1 || I[2] < 1 || I[3] < 0 || I[3] > 2
        || I[4] < I[1] || I[1] - 3 * (I[4] - I[1]) < 0 || (size_t)ni != ints_needed(I[0])) {
        PyBuffer_Release(bi);
        PyErr_SetString(PyExc_ValueError, "malformed integer table");
        return -1;
    }
    for (int i = 0; i < I[0]; i++) {
        const int *b = I + HEAD + STRIDE * i;
        int p = b[0], k = b[1], j = b[2], c = b[3], u = b[4];
        int sphere = k == SPHERICAL && c >= I[1] - 3 * (I[4] - I[1]) && c + 4 <= I[4]
                     && u >= 0 && u + 3 <= I[1];
        if (p < -1 || p >= i || k < 0 || k > SPHERICAL || j < -1
            || j + (k == SPHERICAL ? 3 : 1) > I[2] || ((k == 0) != (j < 0))
            || (k == SPHERICAL ? !sphere : (c != -1 || u != -1))) {
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

/* out = [W(q) u, du] */
static int rhs(const Model *m, const double *x, const double *e, double *out) {
    rates(m, x, out);
    return accelerations(m, x, e, out + m->nq);
}

typedef int (*state_kernel)(const Model *, const double *, const double *, double *);

/* f(ints, doubles, x, e, out) for a kernel of the state x (NQ + N) and the joint
   efforts e (NM) writing NQ + N values, or (NQ + N)^2 when square */
static PyObject *state_call(PyObject *const *args, Py_ssize_t nargs, state_kernel f, int square) {
    if (nargs != 5) { PyErr_SetString(PyExc_TypeError, "expected (ints, doubles, x, e, out)"); return NULL; }
    Py_buffer bi, bd, bx, be, bo;
    Model m;
    if (tables(args, &bi, &bd, &m) < 0) return NULL;
    int code = -1;
    Py_ssize_t ns = m.nq + m.n;
    if (buffer(args[2], &bx, "d", 8, ns, 0) == 0) {
        if (buffer(args[3], &be, "d", 8, m.nm, 0) == 0) {
            if (buffer(args[4], &bo, "d", 8, ns * (square ? ns : 1), 1) == 0) {
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

/* rhs(ints, doubles, x, e, out): out = [W(q) u, du] -> code */
static PyObject *py_rhs(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return state_call(args, nargs, rhs, 0);
}

/* jac(ints, doubles, x, e, J): J ((NQ + N)^2) -> code */
static PyObject *py_jac(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return state_call(args, nargs, jacobian, 1);
}

typedef int (*point_kernel)(const Model *, const double *, const double *, double *);

/* f at each of count states x[k] (NQ + N), with w[k] (N) when with_w, writing out[k]
   (width values; 0: N): f(ints, doubles, count, x, [w,] out) -> code */
static PyObject *batch_call(PyObject *const *args, Py_ssize_t nargs, point_kernel f, int with_w,
                            int width) {
    if (nargs != 5 + with_w) {
        PyErr_SetString(PyExc_TypeError, with_w ? "expected (ints, doubles, count, x, w, out)"
                                                : "expected (ints, doubles, count, x, out)");
        return NULL;
    }
    Py_buffer bi, bd, bx, bw, bo;
    Model m;
    Py_ssize_t count = PyLong_AsSsize_t(args[2]);
    if (count < 0) { if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "count < 0"); return NULL; }
    if (tables(args, &bi, &bd, &m) < 0) return NULL;
    int code = -1;
    Py_ssize_t ns = m.nq + m.n, wo = width ? width : m.n, ww = with_w ? m.n : 0;
    if (buffer(args[3], &bx, "d", 8, ns * count, 0) == 0) {
        if (!with_w || buffer(args[4], &bw, "d", 8, m.n * count, 0) == 0) {
            if (buffer(args[4 + with_w], &bo, "d", 8, wo * count, 1) == 0) {
                const double *x = (const double *)bx.buf, *w = with_w ? (const double *)bw.buf : NULL;
                double *o = (double *)bo.buf;
                code = 0;
                for (Py_ssize_t k = 0; k < count && !code; k++)
                    code = f(&m, x + ns * k, w ? w + ww * k : NULL, o + wo * k);
                PyBuffer_Release(&bo);
            }
            if (with_w) PyBuffer_Release(&bw);
        }
        PyBuffer_Release(&bx);
    }
    PyBuffer_Release(&bi); PyBuffer_Release(&bd);
    return code < 0 ? NULL : PyLong_FromLong(code);
}

static int inverse_at(const Model *m, const double *x, const double *w, double *out) {
    return inverse(m, x, x + m->nq, w, out);
}

static int energies_at(const Model *m, const double *x, const double *w, double *out) {
    (void)w; return energies(m, x, out);
}

/* inverse(ints, doubles, count, x, w, out): out[k] = M w[k] - F at x[k] = [q, u]
   (no actuators) */
static PyObject *py_inverse(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return batch_call(args, nargs, inverse_at, 1, 0);
}

/* energies(ints, doubles, count, x, out): out[k] = [T, V, P_d] at x[k] = [q, u]
   (``energies``) */
static PyObject *py_energies(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self; return batch_call(args, nargs, energies_at, 0, 3);
}

/* mass(ints, doubles, q, out): out = M(q) (N x N, q: NQ) by composite rigid bodies */
static PyObject *py_mass(PyObject *self, PyObject *const *args, Py_ssize_t nargs) {
    (void)self;
    if (nargs != 4) { PyErr_SetString(PyExc_TypeError, "expected (ints, doubles, q, out)"); return NULL; }
    Py_buffer bi, bd, bq, bo;
    Model m;
    if (tables(args, &bi, &bd, &m) < 0) return NULL;
    int code = -1;
    if (buffer(args[2], &bq, "d", 8, m.nq, 0) == 0) {
        if (buffer(args[3], &bo, "d", 8, m.n * m.n, 1) == 0) {
            Frame *F = malloc(sizeof(Frame) * m.nb);
            double *th = malloc(sizeof(double) * (m.nm + m.nm * m.nm + m.nm * m.n));
            code = 1;
            if (F && th) {
                positions(&m, (const double *)bq.buf, th);
                frames(&m, (const double *)bq.buf, th, F, NULL);
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
    {"energies", (PyCFunction)(void (*)(void))py_energies, METH_FASTCALL,
     "energies(ints, doubles, count, x, out) -> code"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, MODULE_NAME, NULL, -1, methods};

PyMODINIT_FUNC INIT_FUNCTION(void) { return PyModule_Create(&module); }
