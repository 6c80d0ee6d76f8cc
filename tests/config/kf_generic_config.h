/* DKF_CONFIG_FILE of the dkf_kf_generic test library (tests/CMakeLists.txt):
 * no Kalman or Difference-KF step compiled for a fixed size, so every size
 * runs the generic step; no vector extension (DKF_SIMD 0), so every
 * kernel runs its plain C99 form; and no loop peeling (DKF_PEEL_LOOPS 0).
 * kf_paths_identical then compares the default build (fixed sizes,
 * vectors where the target has them, peeled loops) with the plainest one,
 * bit for bit. Nothing else differs from the dkf build. */
#define DKF_KF_FIXED_SIZES(X)
#define DKF_DIFFKF_FIXED_SIZES(X)
#define DKF_SIMD 0
#define DKF_PEEL_LOOPS 0
