/*
 * dkf/version.h - the version of the dkf headers, and of the library.
 *
 * The three numbers below are the only place the version is written: the
 * top-level CMakeLists.txt reads them into project(dkf VERSION ...), which
 * gives the package version (find_package(dkf 0.1)) and the shared
 * library's SONAME, so they cannot disagree. DKF_VERSION_STRING is made
 * from them. dkf_version_str() returns the string the library was compiled
 * with: a program that finds it different from DKF_VERSION_STRING runs
 * against another library than the headers it was compiled with (a
 * shared libdkf replaced underneath it).
 */
#ifndef DKF_VERSION_H
#define DKF_VERSION_H

#define DKF_VERSION_MAJOR 0
#define DKF_VERSION_MINOR 1
#define DKF_VERSION_PATCH 0

#define DKF__VERSION_STR(x) #x
#define DKF__VERSION_XSTR(x) DKF__VERSION_STR(x)
/* "MAJOR.MINOR.PATCH", e.g. "0.1.0". */
#define DKF_VERSION_STRING \
    DKF__VERSION_XSTR(DKF_VERSION_MAJOR) "." DKF__VERSION_XSTR(DKF_VERSION_MINOR) "." \
    DKF__VERSION_XSTR(DKF_VERSION_PATCH)

#ifdef __cplusplus
extern "C" {
#endif

/* DKF_VERSION_STRING as the library was compiled. Never NULL. */
const char *dkf_version_str(void);

#ifdef __cplusplus
}
#endif

#endif /* DKF_VERSION_H */
