/* TEMPORARY STUB on main until branch h/ric (the doubling solvers) merges: plain iterations, no checks. */
#include "dkf/mat_riccati.h"
#include "internal.h"
#include "kernels.h"
dkf_status_t dkf_mat_dare(dkf_mat_t *X, const dkf_mat_t *F, const dkf_mat_t *H,
                          const dkf_mat_t *Q, const dkf_mat_t *R, dkf_real_t *work)
{
    size_t n = F->rows, m = H->rows, it, i, j;
    dkf_real_t *P = work, *T = P + n * n, *B = T + n * n, *S = B + n * m, *Kt = S + m * m, *Pn = Kt + n * m;
    dkf_real_t inv[DKF_MAX_DIM];
    dkf__copy(P, Q->data, n * n);
    for (it = 0; it < 20000; ++it) {
        dkf__mul_nn(B, H->data, P, m, n, n);
        dkf__mul_nt_sym(S, B, H->data, R->data, m, n);
        dkf__chol(S, inv, S, m);
        dkf__copy(Kt, B, m * n);
        dkf__chol_solve(S, inv, Kt, m, n);
        /* Pu = P - B^T Kt */
        for (i = 0; i < n; ++i) for (j = 0; j < n; ++j) { size_t a; dkf_real_t v = P[i*n+j]; for (a = 0; a < m; ++a) v -= B[a*n+i]*Kt[a*n+j]; T[i*n+j] = v; }
        dkf__mul_nn(Pn, F->data, T, n, n, n);
        dkf__mul_nt_sym(T, Pn, F->data, Q->data, n, n);
        dkf__copy(P, T, n * n);
    }
    dkf__copy(X->data, P, n * n);
    return DKF_OK;
}
dkf_status_t dkf_mat_stein(dkf_mat_t *X, const dkf_mat_t *A, const dkf_mat_t *B,
                           const dkf_mat_t *C, dkf_real_t *work)
{
    size_t r = A->rows, c = B->rows, it;
    dkf_real_t *Y = work, *T = Y + r * c, *U = T + r * c;
    dkf__copy(Y, C->data, r * c);
    for (it = 0; it < 5000; ++it) {
        dkf__mul_nn(T, A->data, Y, r, r, c);
        dkf__mul_nt(U, T, B->data, r, c, c);
        for (size_t e = 0; e < r * c; ++e) U[e] += C->data[e];
        dkf__copy(Y, U, r * c);
    }
    dkf__copy(X->data, Y, r * c);
    return DKF_OK;
}
