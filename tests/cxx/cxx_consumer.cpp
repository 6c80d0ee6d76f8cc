/*
 * A C++ program on the C library (tests/cxx/CMakeLists.txt): every public
 * header, every declared function by address, and a few modules run.
 * Exit status 0 when every check holds.
 */
#include <cmath>
#include <cstdio>
#include <cstring>

#include "dkf_all_headers.h"

/* The version macros are CMake's project version (project() reads them
 * from dkf/version.h; this checks that reading). */
static_assert(DKF_VERSION_MAJOR == CXX_CONSUMER_VERSION_MAJOR &&
                  DKF_VERSION_MINOR == CXX_CONSUMER_VERSION_MINOR &&
                  DKF_VERSION_PATCH == CXX_CONSUMER_VERSION_PATCH,
              "dkf/version.h and the CMake project version differ");

/* Every function the headers declare, by address, in a table the compiler
 * must keep (external linkage): a declaration outside extern "C" names a
 * C++-mangled symbol, which libdkf does not define, and the link fails.
 * void (*)(void) is the type every function pointer may be cast to and
 * back without a -Wcast-function-type warning. */
typedef void (*any_function)(void);
extern const any_function dkf_cxx_functions[];
const any_function dkf_cxx_functions[] = {
#define DKF_CXX_FUNCTION(f) reinterpret_cast<any_function>(&f),
#include "dkf_functions.inc"
#undef DKF_CXX_FUNCTION
};

static int failures = 0;

static void check(bool ok, const char *what)
{
    if (!ok) {
        std::printf("cxx_consumer: FAILED: %s\n", what);
        ++failures;
    }
}

static bool close_to(dkf_real_t got, dkf_real_t want, double tol)
{
    const double g = static_cast<double>(got), w = static_cast<double>(want);
    return std::fabs(g - w) <= tol * (1.0 + std::fabs(w));
}

int main()
{
    const std::size_t n_functions = sizeof dkf_cxx_functions / sizeof dkf_cxx_functions[0];
    /* sqrt(eps): far above the rounding of 2 x 2 arithmetic, far below a
     * wrong formula. */
    const double tol = std::sqrt(static_cast<double>(DKF_REAL_EPSILON));

    check(std::strcmp(DKF_VERSION_STRING, CXX_CONSUMER_VERSION) == 0,
          "DKF_VERSION_STRING is the CMake project version");
    check(std::strcmp(dkf_version_str(), DKF_VERSION_STRING) == 0,
          "dkf_version_str() is DKF_VERSION_STRING");
    check(std::strcmp(dkf_status_str(DKF_ERR_NOT_SPD), "matrix not SPD") == 0, "dkf_status_str");

    /* Constant velocity, F = [1 1; 0 1], Q = 0.01 I, H = [1 0], R = 0.25:
     * after enough steps the Kalman filter's predicted covariance is the
     * stabilising solution of the DARE (kf, mat_riccati). */
    dkf_real_t F_d[] = {1, 1, 0, 1}, Q_d[] = {DKF_R(0.01), 0, 0, DKF_R(0.01)}, H_d[] = {1, 0};
    dkf_real_t R_d[] = {DKF_R(0.25)}, x0_d[] = {0, 1}, P0_d[] = {4, 0, 0, 4}, y_d[1], X_d[4];
    const dkf_mat_t F = DKF_MAT(2, 2, F_d), Q = DKF_MAT(2, 2, Q_d), H = DKF_MAT(1, 2, H_d);
    const dkf_mat_t R = DKF_MAT(1, 1, R_d), x0 = DKF_MAT(2, 1, x0_d), P0 = DKF_MAT(2, 2, P0_d);
    dkf_mat_t y = DKF_MAT(1, 1, y_d), X = DKF_MAT(2, 2, X_d);
    static dkf_real_t dare_work[DKF_MAT_DARE_WORK(2, 1)];
    DKF_KF_DECLARE(, kf, 2, 1);
    dkf_status_t s =
        dkf_kf_init(&kf, 2, 1, kf_storage, sizeof kf_storage / sizeof kf_storage[0], &x0, &P0);
    const dkf_kf_dyn_t dyn = {&F, &Q};
    const dkf_kf_meas_t meas = {&H, &R};
    for (int k = 0; k < 500 && s == DKF_OK; ++k) {
        s = dkf_kf_predict(&kf, &dyn, NULL);
        y_d[0] = static_cast<dkf_real_t>(k) + DKF_R(0.5) * static_cast<dkf_real_t>(k % 3 - 1);
        if (s == DKF_OK) s = dkf_kf_update(&kf, &meas, &y);
    }
    if (s == DKF_OK) s = dkf_kf_predict(&kf, &dyn, NULL);
    if (s == DKF_OK) s = dkf_mat_dare(&X, &F, &H, &Q, &R, dare_work);
    check(s == DKF_OK, dkf_status_str(s));
    for (int i = 0; i < 4 && s == DKF_OK; ++i)
        check(close_to(kf.P.data[i], X.data[i], tol), "the filter's P converges to the DARE's X");

    /* A path of 3 nodes with Metropolis weights: connected, doubly
     * stochastic (graph). */
    const std::size_t edges[] = {0, 1, 1, 2};
    std::size_t start[4], nbr[DKF_GRAPH_NNZ(3, 2)], work[3];
    dkf_real_t w[DKF_GRAPH_NNZ(3, 2)];
    dkf_graph_t g;
    s = dkf_graph_from_edges(&g, start, nbr, sizeof nbr / sizeof nbr[0], 3, edges, 2);
    if (s == DKF_OK) s = dkf_graph_connected(&g, work);
    if (s == DKF_OK) s = dkf_graph_weights_metropolis(w, &g);
    if (s == DKF_OK) s = dkf_graph_check_doubly_stochastic(&g, w);
    check(s == DKF_OK, dkf_status_str(s));

    std::printf("cxx_consumer: dkf %s, %u functions linked by address, "
                "X = [%.6g %.6g; %.6g %.6g]: %s\n",
                dkf_version_str(), static_cast<unsigned>(n_functions),
                static_cast<double>(X.data[0]), static_cast<double>(X.data[1]),
                static_cast<double>(X.data[2]), static_cast<double>(X.data[3]),
                failures ? "FAILED" : "ok");
    return failures ? 1 : 0;
}
