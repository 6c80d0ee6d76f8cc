/*
 * wire.c - LCM's unfragmented udpm datagram (wire.h).
 */
#define _POSIX_C_SOURCE 200809L /* strnlen */

#include "wire.h"

#include <string.h>

static uint32_t get_be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

static void put_be32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

dkf_wire_verdict_t dkf_wire_parse(const unsigned char *dgram, size_t len, dkf_wire_msg_t *msg)
{
    const unsigned char *nul;
    size_t room, clen;
    uint32_t magic;
    if (len < DKF_WIRE_HEADER) return DKF_WIRE_BAD;
    magic = get_be32(dgram);
    if (magic == DKF_WIRE_MAGIC_LONG) return DKF_WIRE_FRAGMENT;
    if (magic != DKF_WIRE_MAGIC_SHORT) return DKF_WIRE_BAD;
    room = len - DKF_WIRE_HEADER;
    if (room > DKF_WIRE_MAX_CHANNEL + 1) room = DKF_WIRE_MAX_CHANNEL + 1;
    nul = memchr(dgram + DKF_WIRE_HEADER, 0, room);
    if (nul == NULL) return DKF_WIRE_BAD; /* no NUL within 64 bytes, or none at all */
    clen = (size_t)(nul - (dgram + DKF_WIRE_HEADER));
    if (clen == 0) return DKF_WIRE_BAD;
    msg->seqno = get_be32(dgram + 4);
    msg->channel = (const char *)(dgram + DKF_WIRE_HEADER);
    msg->channel_len = clen;
    msg->data = nul + 1;
    msg->len = len - DKF_WIRE_HEADER - clen - 1;
    return DKF_WIRE_OK;
}

size_t dkf_wire_pack(unsigned char *out, size_t cap, uint32_t seqno, const char *channel,
                     const void *data, size_t len)
{
    const size_t clen = strnlen(channel, DKF_WIRE_MAX_CHANNEL + 1);
    size_t total;
    if (clen == 0 || clen > DKF_WIRE_MAX_CHANNEL) return 0;
    if (len > DKF_WIRE_MAX_DATAGRAM - DKF_WIRE_HEADER - clen - 1) return 0;
    total = DKF_WIRE_HEADER + clen + 1 + len;
    if (total > cap) return 0;
    put_be32(out, DKF_WIRE_MAGIC_SHORT);
    put_be32(out + 4, seqno);
    memcpy(out + DKF_WIRE_HEADER, channel, clen + 1);
    if (len > 0) memcpy(out + DKF_WIRE_HEADER + clen + 1, data, len);
    return total;
}
