/*
 * clock.c - the network processes' clocks (clock.h).
 */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */

#include "clock.h"

#include <time.h>

static int64_t clock_us(clockid_t id)
{
    struct timespec ts;
    clock_gettime(id, &ts);
    return (int64_t)ts.tv_sec * 1000000 + (int64_t)(ts.tv_nsec / 1000);
}

static int64_t offset_us; /* dkf_net_clock_set_offset_us */

int64_t dkf_net_now_us(void) { return clock_us(CLOCK_REALTIME) + offset_us; }
void dkf_net_clock_set_offset_us(int64_t us) { offset_us = us; }
int64_t dkf_net_clock_offset_us(void) { return offset_us; }
int64_t dkf_net_mono_us(void) { return clock_us(CLOCK_MONOTONIC); }
