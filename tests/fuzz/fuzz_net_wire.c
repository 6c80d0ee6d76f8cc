/*
 * fuzz_net_wire.c - the reader of LCM's udpm datagrams (ports/linux/net/
 * wire.h), which the direct receive of net.h runs on everything that
 * arrives on a port it reads: the input is one datagram. Properties:
 *   - a datagram refused (bad, or a fragment) leaves the output untouched;
 *     a fragment is exactly a datagram of 8 bytes or more starting "LC03";
 *   - an accepted one names a channel of 1..63 bytes without NUL, ended by
 *     a NUL inside the datagram, and a payload that is the rest of it;
 *   - packing what was read (where LCM would send it whole) gives back the
 *     input bytes.
 */
#include <stdint.h>
#include <string.h>

#include "fuzz_check.h"
#include "wire.h"

static unsigned char re[DKF_WIRE_MAX_DATAGRAM];

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    dkf_wire_msg_t m, before;
    dkf_wire_verdict_t v;
    memset(&before, 0x5a, sizeof before);
    m = before;
    v = dkf_wire_parse(data, size, &m);
    FUZZ_REQUIRE(v == DKF_WIRE_OK || v == DKF_WIRE_FRAGMENT || v == DKF_WIRE_BAD);
    FUZZ_REQUIRE((v == DKF_WIRE_FRAGMENT) == (size >= 8 && memcmp(data, "LC03", 4) == 0));
    if (v != DKF_WIRE_OK) {
        FUZZ_REQUIRE(memcmp(&m, &before, sizeof m) == 0);
        return 0;
    }
    FUZZ_REQUIRE(size >= DKF_WIRE_HEADER + 2 && memcmp(data, "LC02", 4) == 0);
    FUZZ_REQUIRE(m.channel == (const char *)data + DKF_WIRE_HEADER);
    FUZZ_REQUIRE(m.channel_len >= 1 && m.channel_len <= DKF_WIRE_MAX_CHANNEL);
    FUZZ_REQUIRE(memchr(m.channel, 0, m.channel_len) == NULL && m.channel[m.channel_len] == 0);
    FUZZ_REQUIRE(m.data == data + DKF_WIRE_HEADER + m.channel_len + 1);
    FUZZ_REQUIRE(m.len == size - DKF_WIRE_HEADER - m.channel_len - 1);
    FUZZ_REQUIRE(m.seqno == ((uint32_t)data[4] << 24 | (uint32_t)data[5] << 16 |
                             (uint32_t)data[6] << 8 | (uint32_t)data[7]));
    if (size <= DKF_WIRE_MAX_DATAGRAM) {
        FUZZ_REQUIRE(dkf_wire_pack(re, sizeof re, m.seqno, m.channel, m.data, m.len) == size);
        FUZZ_REQUIRE(memcmp(re, data, size) == 0);
    } else {
        FUZZ_REQUIRE(dkf_wire_pack(re, sizeof re, m.seqno, m.channel, m.data, m.len) == 0);
    }
    return 0;
}
