/*
 * dkf/build_config.h - the options a built libdkf.a was compiled with.
 *
 * This copy in the source tree records none (a compile of the sources
 * without CMake takes config.h's defaults). A CMake build generates its own
 * from cmake/build_config.h.in into <build>/include/dkf/, which comes
 * first on the library's include path, and `cmake --install` installs that
 * one: it fixes DKF_USE_FLOAT, DKF_MAX_DIM, DKF_JOSEPH, DKF_DEBUG_CHECKS
 * and DKF_SVD_MAX_SWEEPS to the built values and stops a
 * consumer that defines others with an #error (docs/guide/build.md).
 */
#ifndef DKF_BUILD_CONFIG_H
#define DKF_BUILD_CONFIG_H
#endif /* DKF_BUILD_CONFIG_H */
