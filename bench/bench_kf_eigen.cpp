/*
 * bench/bench_kf_eigen.cpp - the reference: the same Kalman step as
 * src/kf.c, written the way one writes it with Eigen 3.4 fixed-size
 * matrices (Matrix<Real, N, N>, LLT for S). Built twice by
 * bench/CMakeLists.txt: -O2, and -O3 -march=native.
 *
 * Same models, data, timing and checksum as bench_kf.c (bench_common.h).
 * The arithmetic follows src/kf.c formula for formula (Joseph form when
 * the library is built with DKF_JOSEPH=1; every stored covariance made
 * exactly symmetric by mirroring its upper triangle, as kf.c does), so the
 * checksums agree to rounding: only the order of the sums inside the
 * products differs, and Eigen computes whole products where kf.c computes
 * only the upper triangle.
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
        VecN x = md.x0;
        MatN P = md.P0;
        for (long k = 0; k < steps; ++k) {
            const VecM &y = md.Y[k % BENCH_NMEAS];

            // Predict: x = F x; P = (F P) F^T + Q, upper triangle mirrored
            // (src/kf.c computes only the upper triangle and mirrors it).
            x = md.F * x;
            const MatN Pp = md.F * P * md.F.transpose() + md.Q;
            P = Pp.template selfadjointView<Eigen::Upper>();

            // Update: nu = y - H x; PHt = P H^T; S = H PHt + R (mirrored);
            // Kt = K^T = S^{-1} PHt^T by Cholesky; NIS = |L^{-1} nu|^2.
            const VecM nu = y - md.H * x;
            const MatNM PHt = P * md.H.transpose();
            const MatM Su = md.H * PHt + md.R;
            const MatM S = Su.template selfadjointView<Eigen::Upper>();
            const Eigen::LLT<MatM> llt(S);
            if (llt.info() != Eigen::Success) return NAN;
            const MatMN Kt = llt.solve(PHt.transpose());
            g_nis = llt.matrixL().solve(nu).squaredNorm();
            x += Kt.transpose() * nu;
#if BENCH_JOSEPH
            // Joseph form: A = I - K H; P = (A P) A^T + (K R) K^T, upper
            // triangle mirrored (exactly symmetric, as in src/kf.c).
            const MatN A = MatN::Identity() - Kt.transpose() * md.H;
            const MatNM KR = Kt.transpose() * md.R;
            const MatN Pj = A * P * A.transpose() + KR * Kt;
            P = Pj.template selfadjointView<Eigen::Upper>();
#else
            // P = P - PHt Kt (= P - K S K^T), upper triangle mirrored.
            const MatN Ps = P - PHt * Kt;
            P = Ps.template selfadjointView<Eigen::Upper>();
#endif
        }
        return (double)x.sum() + (double)P.trace();
    }
};

template <int N, int M>
typename Case<N, M>::Model Case<N, M>::md;

int g_case;

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

} // namespace

int main(int argc, char **argv)
{
    return bench_main(argc, argv, BENCH_VARIANT, BENCH_TYPE, prepare, run);
}
