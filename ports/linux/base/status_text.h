/*
 * status_text.h - what a failed core call of a host run means, in one
 * phrase: the status, and the matrix the status is about for that call
 * (the calls' own headers, dkf/<filter>.h). The host reads only finite
 * numbers (the scenario reader refuses others), so a non-finite value
 * in a run is an overflow of finite inputs and is called one.
 * docs/decisions.md item 52.
 */
#ifndef DKF_HOST_STATUS_TEXT_H
#define DKF_HOST_STATUS_TEXT_H

#include <stddef.h>

#include "dkf/status.h"

/* Bytes that always hold a dkf_host_status_text. */
#define DKF_STATUS_TEXT_LEN 320

/* "STATUS (CODE): MATRIX is not ..." for status st of the core call named
 * in call (a function name, possibly after a "node 3: " prefix) into out
 * (len bytes); the matrix part is left out where the call's header names
 * none for st. Returns out. */
const char *dkf_host_status_text(char *out, size_t len, const char *call, dkf_status_t st);

#endif /* DKF_HOST_STATUS_TEXT_H */
