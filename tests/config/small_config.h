/* A user configuration header for the DKF_CONFIG_FILE hook test. */
#define DKF_MAX_DIM 8
#define DKF_DEBUG_CHECKS 0
