/*
 * clock.h - the network processes' clocks (host side): wall-clock time for
 * message stamps (comparable between processes on one host) and monotonic
 * time for deadlines, both in microseconds. The transport (net.h) and
 * authentication (auth.h: a sender's epoch is its start time) read them here.
 */
#ifndef DKF_NET_CLOCK_H
#define DKF_NET_CLOCK_H

#include <stdint.h>

/* CLOCK_REALTIME: microseconds since the epoch (plus the offset below). */
int64_t dkf_net_now_us(void);

/* A test option (the programs' --clock-offset-ms; docs/guide/network.md,
 * "Several hosts"): from now on dkf_net_now_us reads CLOCK_REALTIME +
 * offset_us, as on a host whose clock is that far off, and the transport
 * (net.h) reports its receive times on the same clock. 0 by default. */
void dkf_net_clock_set_offset_us(int64_t offset_us);
int64_t dkf_net_clock_offset_us(void);
/* CLOCK_MONOTONIC: microseconds since an arbitrary start. */
int64_t dkf_net_mono_us(void);

#endif /* DKF_NET_CLOCK_H */
