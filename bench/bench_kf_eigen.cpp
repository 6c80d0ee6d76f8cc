/*
 * bench/bench_kf_eigen.cpp - the reference: the Kalman step a competent
 * Eigen 3.4 user writes with fixed-size matrices (Matrix<Real, N, N>, LLT
 * for S), i.e. what one would pick instead of dkf. Built twice by
 * bench/CMakeLists.txt: -O2, and -O3 -march=native.
 *
 * Same models, data, timing and checksum as bench_kf.c (bench_common.h).
 * It is written from the textbook formulas, not from src/kf.c's algorithm:
 *   predict  x = F x,  P = F P F^T + Q;
 *   update   nu = y - H x,  S = H P H^T + R,  K = P H^T S^{-1} (LLT),
 *            NIS = nu^T S^{-1} nu,  x += K nu,
 *            P = (I - K H) P (I - K H)^T + K R K^T   (Joseph, DKF_JOSEPH=1)
 *            or P -= K H P                           (DKF_JOSEPH=0),
 * and P made exactly symmetric after each step (upper triangle mirrored),
 * as dkf stores it. The mathematical quantities are those of dkf, so the
 * checksums agree to rounding (different evaluation orders only).
 *
 * BENCH_USE_FLOAT (set from DKF_REAL by CMake) picks the real type;
 * BENCH_JOSEPH (from DKF_JOSEPH) the covariance update.
 */
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "bench_common.h"

#if BENCH_USE_FLOAT
typedef float Real;
#define BENCH_TYPE "float"
#else
typedef double Real;
#define BENCH_TYPE "double"
#endif

#ifndef BENCH_JOSEPH
#define BENCH_JOSEPH 1
#endif

#ifndef BENCH_VARIANT
#define BENCH_VARIANT "eigen"
#endif

namespace {

// NIS of the last update: kept observable like dkf's kf->nis, so the
// compiler cannot drop its computation.
volatile Real g_nis;

template <int N, int M>
struct Case {
    typedef Eigen::Matrix<Real, N, N> MatN;
    typedef Eigen::Matrix<Real, M, M> MatM;
    typedef Eigen::Matrix<Real, M, N> MatMN;
    typedef Eigen::Matrix<Real, N, M> MatNM;
    typedef Eigen::Matrix<Real, N, 1> VecN;
    typedef Eigen::Matrix<Real, M, 1> VecM;

    struct Model {
        MatN F, Q, P0;
        MatMN H;
        MatM R;
        VecN x0;
        VecM Y[BENCH_NMEAS];
    };
    static Model md;

    template <int R, int C>
    static Eigen::Matrix<Real, R, C> load(const double *rowmajor)
    {
        typedef Eigen::Matrix<double, R, C, (C == 1 ? Eigen::ColMajor : Eigen::RowMajor)> Src;
        return Eigen::Map<const Src>(rowmajor).template cast<Real>();
    }

    static void prepare(const bench_model_t *m)
    {
        md.F = load<N, N>(m->F);
        md.Q = load<N, N>(m->Q);
        md.P0 = load<N, N>(m->P0);
        md.H = load<M, N>(m->H);
        md.R = load<M, M>(m->R);
        md.x0 = load<N, 1>(m->x0);
        for (int k = 0; k < BENCH_NMEAS; ++k) md.Y[k] = load<M, 1>(m->Y + k * M);
    }

    static double run(long steps)
    {
        const MatM I = MatM::Identity();
        VecN x = md.x0;
        MatN P = md.P0;
        for (long k = 0; k < steps; ++k) {
            const VecM &y = md.Y[k % BENCH_NMEAS];

            // Predict.
            x = md.F * x;
            P = md.F * P * md.F.transpose() + md.Q;
            P = P.template selfadjointView<Eigen::Upper>(); // symmetrise, as dkf does

            // Update: innovation, its covariance, gain through a Cholesky
            // factorisation of S.
            const VecM nu = y - md.H * x;
            const MatM S = md.H * P * md.H.transpose() + md.R;
            const Eigen::LLT<MatM> llt(S);
            if (llt.info() != Eigen::Success) return NAN;
            const MatNM K = P * md.H.transpose() * llt.solve(I);
            g_nis = nu.dot(llt.solve(nu));
            x += K * nu;
#if BENCH_JOSEPH
            const MatN A = MatN::Identity() - K * md.H;
            P = A * P * A.transpose() + K * md.R * K.transpose();
#else
            P -= K * md.H * P;
#endif
            P = P.template selfadjointView<Eigen::Upper>(); // symmetrise, as dkf does
        }
        return (double)x.sum() + (double)P.trace();
    }
};

template <int N, int M>
typename Case<N, M>::Model Case<N, M>::md;

int g_case;

#ifdef BENCH_ONLY_LARGEST
// The compile check of bench/CMakeLists.txt (bench_eigen_avx512_builds):
// the largest case alone, which is where GCC's AVX-512 warnings come from;
// the others would triple the compile time and check nothing more.
void prepare(int c, const bench_model_t *m)
{
    g_case = c;
    Case<12, 6>::prepare(m);
}

double run(long steps) { return Case<12, 6>::run(steps); }
#else
void prepare(int c, const bench_model_t *m)
{
    g_case = c;
    switch (c) {
    case 0: Case<4, 2>::prepare(m); break;
    case 1: Case<8, 4>::prepare(m); break;
    default: Case<12, 6>::prepare(m); break;
    }
}

double run(long steps)
{
    switch (g_case) {
    case 0: return Case<4, 2>::run(steps);
    case 1: return Case<8, 4>::run(steps);
    default: return Case<12, 6>::run(steps);
    }
}
#endif

} // namespace

int main(int argc, char **argv)
{
    return bench_main(argc, argv, BENCH_VARIANT, BENCH_TYPE, prepare, run);
}
