/*
 * hypotf_double.c - hypotf as the x86-64 host's C library computes it,
 * for the emulated-M4 image (docs/decisions.md, decision 62).
 *
 * The core's float build calls hypotf (DKF_HYPOT: Householder norms in
 * mat_qr.c, Jacobi rotations in mat_svd.c). glibc (2.35 and later) returns
 * sqrt(x^2 + y^2) evaluated in double, rounded once to float; newlib's
 * hypotf is fdlibm's float algorithm, within one ulp but not always the
 * same float. This definition, linked before newlib's libm, gives the image
 * glibc's results, so that it can equal the host float build bit for bit.
 * The squares of two floats are exact in double; the sum and the square
 * root round once each (libgcc's and newlib's double routines are IEEE).
 */
#include <math.h>

#include "dkf/config.h"

#if DKF_USE_FLOAT
float hypotf(float x, float y)
{
    const double xd = (double)x, yd = (double)y;
    if (isinf(x) || isinf(y)) return INFINITY;
    if (isnan(x) || isnan(y)) return x + y;
    return (float)sqrt(xd * xd + yd * yd);
}
#endif
