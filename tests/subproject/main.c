/*
 * The program of tests/subproject: dkf's version as headers and library
 * see it, and one Cholesky solve. Exit status 0 when both are right.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "dkf/mat.h"
#include "dkf/version.h"

int main(void)
{
    /* A = [4 2; 2 3], b = [2; 1]: x = A^-1 b = [0.5; 0]. */
    DKF_MAT_DECLARE(, A, 2, 2);
    DKF_MAT_DECLARE(, L, 2, 2);
    DKF_MAT_DECLARE(, x, 2, 1);
    dkf_real_t work[DKF_MAT_CHOL_WORK(2)];
    dkf_status_t s;

    A_data[0] = DKF_R(4.0); A_data[1] = DKF_R(2.0); A_data[2] = DKF_R(2.0); A_data[3] = DKF_R(3.0);
    x_data[0] = DKF_R(2.0); x_data[1] = DKF_R(1.0);
    s = dkf_mat_chol(&L, &A, work);
    if (s == DKF_OK) s = dkf_mat_chol_solve(&x, &L, &x);
    if (s != DKF_OK) {
        printf("subproject: %s\n", dkf_status_str(s));
        return 1;
    }
    if (strcmp(dkf_version_str(), DKF_VERSION_STRING) != 0) {
        printf("subproject: library %s, headers %s\n", dkf_version_str(), DKF_VERSION_STRING);
        return 1;
    }
    if (fabs((double)x_data[0] - 0.5) > 1e-6 || fabs((double)x_data[1]) > 1e-6) {
        printf("subproject: x = [%g %g], want [0.5 0]\n", (double)x_data[0], (double)x_data[1]);
        return 1;
    }
    printf("subproject: dkf %s ok\n", dkf_version_str());
    return 0;
}
