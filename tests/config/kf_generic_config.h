/* DKF_CONFIG_FILE of the dkf_kf_generic test library (tests/CMakeLists.txt):
 * no Kalman step compiled for a fixed size, so every (n, m) runs the
 * generic step. Nothing else differs from the dkf build. */
#define DKF_KF_FIXED_SIZES(X)
