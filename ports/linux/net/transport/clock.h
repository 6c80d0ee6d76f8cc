/*
 * clock.h - the network processes' clocks (host side): wall-clock time for
 * message stamps (comparable between processes on one host) and monotonic
 * time for deadlines, both in microseconds. The transport (net.h) and
 * authentication (auth.h: a sender's epoch is its start time) read them here.
 */
#ifndef DKF_NET_CLOCK_H
#define DKF_NET_CLOCK_H

#include <stdint.h>

/* CLOCK_REALTIME: microseconds since the epoch. */
int64_t dkf_net_now_us(void);
/* CLOCK_MONOTONIC: microseconds since an arbitrary start. */
int64_t dkf_net_mono_us(void);

#endif /* DKF_NET_CLOCK_H */
