/* DKF_CONFIG_FILE of the dkf_kf_generic test library (tests/CMakeLists.txt):
 * no Kalman step compiled for a fixed size, so every (n, m) runs the
 * generic step, and no vector extension (DKF_SIMD 0), so every kernel runs
 * its plain C99 form. kf_paths_identical then compares the default build
 * (fixed sizes, vectors where the target has them) with the plainest one,
 * bit for bit. Nothing else differs from the dkf build. */
#define DKF_KF_FIXED_SIZES(X)
#define DKF_SIMD 0
