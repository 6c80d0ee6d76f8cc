/*
 * fused_dump OUT.bin: writes one dkf_lcm.fused_t, encoded by the generated
 * C type exactly as dkf-fusion publishes it (LCM's fingerprint, then the
 * fields), to OUT.bin for tests/lcm_fused_decode.py, which decodes it with
 * the generated Python type (ctest lcm_python_decodes_fused). The values
 * are fixed; the script expects exactly these.
 */
#include <stdio.h>

#include "dkf_lcm_fused_t.h"

int main(int argc, char **argv)
{
    int8_t contributed[3] = {1, 0, 1};
    double xf[2] = {1.5, -2.25}, xp[2] = {1.0, -2.0};
    double pf0[2] = {2.0, 0.5}, pf1[2] = {0.5, 3.0}, pp0[2] = {4.0, 1.0}, pp1[2] = {1.0, 5.0};
    double *Pf[2] = {pf0, pf1}, *Pp[2] = {pp0, pp1};
    unsigned char buf[512];
    dkf_lcm_fused_t m;
    FILE *f;
    int len;
    if (argc != 2) {
        fprintf(stderr, "usage: fused_dump OUT.bin\n");
        return 2;
    }
    m.utime = 1700000000000000LL;
    m.model_id = 42;
    m.k = 7;
    m.seq = 8;
    m.status = DKF_LCM_FUSED_T_DEGRADED;
    m.nnodes = 3;
    m.contributed = contributed;
    m.meas_utime_first = 11;
    m.meas_utime_last = 12;
    m.msg_utime_last = 13;
    m.n = 2;
    m.xf = xf;
    m.xp = xp;
    m.Pf = Pf;
    m.Pp = Pp;
    m.revision = 1;
    len = dkf_lcm_fused_t_encode(buf, 0, (int)sizeof buf, &m);
    if (len <= 0 || len != dkf_lcm_fused_t_encoded_size(&m)) {
        fprintf(stderr, "fused_dump: encode failed (%d)\n", len);
        return 1;
    }
    f = fopen(argv[1], "wb");
    if (f == NULL || fwrite(buf, 1, (size_t)len, f) != (size_t)len || fclose(f) != 0) {
        fprintf(stderr, "fused_dump: cannot write %s\n", argv[1]);
        return 1;
    }
    return 0;
}
