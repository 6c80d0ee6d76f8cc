/*
 * wire.h - LCM's UDP multicast datagram, as the direct receiver of net.h
 * (dkf_net_direct) reads it (host side; docs/guide/network.md, "Direct receive").
 *
 * An LCM publisher sends a message of channel c and payload b in one
 * datagram when it fits (LCM's udpm provider: 8 + |c| + 1 + |b| <= 65499):
 *
 *   "LC02" | seqno u32 | c (1..63 bytes, no NUL) | NUL | b      (big-endian)
 *
 * Longer messages travel as fragments ("LC03" | seqno | size | offset |
 * fragment no | fragment count | ...), which the direct receiver does not
 * reassemble: it counts and drops them (every dkf message is far shorter).
 * A datagram is read whatever its length (up to UDP's 65507 bytes), as
 * LCM's receiver does.
 */
#ifndef DKF_WIRE_H
#define DKF_WIRE_H

#include <stddef.h>
#include <stdint.h>

#define DKF_WIRE_MAGIC_SHORT 0x4c433032u /* "LC02": a whole message */
#define DKF_WIRE_MAGIC_LONG 0x4c433033u  /* "LC03": a fragment */
#define DKF_WIRE_HEADER 8u               /* magic, seqno */
#define DKF_WIRE_MAX_CHANNEL 63u         /* LCM_MAX_CHANNEL_NAME_LENGTH */
#define DKF_WIRE_MAX_DATAGRAM 65499u     /* LCM's largest unfragmented datagram */

typedef enum {
    DKF_WIRE_OK = 0,   /* a whole message: *msg is set */
    DKF_WIRE_FRAGMENT, /* an LC03 fragment (not reassembled) */
    DKF_WIRE_BAD       /* anything else: short, wrong magic, no or long channel */
} dkf_wire_verdict_t;

/* A message inside a datagram: channel is NUL-terminated in place. */
typedef struct {
    uint32_t seqno;
    const char *channel;
    size_t channel_len;
    const unsigned char *data;
    size_t len;
} dkf_wire_msg_t;

/* Reads the len bytes of one datagram. *msg is written only on DKF_WIRE_OK;
 * its pointers point into dgram. */
dkf_wire_verdict_t dkf_wire_parse(const unsigned char *dgram, size_t len, dkf_wire_msg_t *msg);

/* Writes the datagram of (seqno, channel, data[0..len-1]) into out[0..cap-1]
 * as LCM would; its length, or 0 if the channel is empty, longer than
 * DKF_WIRE_MAX_CHANNEL or the datagram would exceed cap or
 * DKF_WIRE_MAX_DATAGRAM. */
size_t dkf_wire_pack(unsigned char *out, size_t cap, uint32_t seqno, const char *channel,
                     const void *data, size_t len);

#endif /* DKF_WIRE_H */
