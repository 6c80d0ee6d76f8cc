/* Compiled (syntax only) with -DDKF_CONFIG_FILE="small_config.h": the
 * user's values must win over every default. */
#include "dkf/config.h"
#include "dkf/kf.h"

DKF_STATIC_ASSERT(DKF_MAX_DIM == 8, user_max_dim_applies);
DKF_STATIC_ASSERT(DKF_DEBUG_CHECKS == 0, user_debug_checks_apply);
DKF_STATIC_ASSERT(DKF_JOSEPH == 1, defaults_fill_the_rest);
/* exact static storage for a small filter still works */
DKF_KF_DECLARE(static, kf, 4, 2);
DKF_STATIC_ASSERT(sizeof kf_storage == DKF_KF_STORAGE_LEN(4, 2) * sizeof(dkf_real_t),
                  storage_is_exact);
int dkf_config_test_anchor(void);
/* reads both, so that no compiler finds them unneeded (clang warns of a
 * static array used only in sizeof) */
int dkf_config_test_anchor(void) { return (int)kf.n + (kf_storage[0] > 0); }
