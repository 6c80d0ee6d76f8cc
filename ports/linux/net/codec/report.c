/*
 * report.c - a process's status message (report.h).
 */
#include "report.h"

int dkf_net_publish_status(dkf_net_t *net, const char *prefix, const dkf_net_status_t *st)
{
    unsigned char buf[512];
    char chan[DKF_NET_CHAN_LEN];
    size_t len;
    if (dkf_net_encode_status(buf, sizeof buf, &len, st) != 0) return -1;
    dkf_net_chan(chan, prefix, "STATUS");
    return dkf_net_publish(net, chan, buf, len);
}
