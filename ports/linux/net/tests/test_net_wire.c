/*
 * LCM's udpm datagram (wire.h), the format the direct receive of net.h
 * reads: datagrams written out byte by byte from LCM's format (not by
 * dkf_wire_pack) are read back, every malformed kind is refused with the
 * output untouched, fragments are told apart, and pack writes exactly the
 * bytes LCM would. The receive path itself over sockets, fed by LCM's own
 * publisher, is the namespace test net_udpm_ex3_direct.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "wire.h"

/* "LC02" | seqno 0x01020304 | "AB" NUL | "xyz" */
static const unsigned char lc02[] = {0x4c, 0x43, 0x30, 0x32, 1,   2,   3,
                                     4,    'A',  'B',  0,    'x', 'y', 'z'};

static void test_reads_lcm_short_datagram(void **state)
{
    dkf_wire_msg_t m;
    (void)state;
    assert_int_equal(dkf_wire_parse(lc02, sizeof lc02, &m), DKF_WIRE_OK);
    assert_int_equal(m.seqno, 0x01020304u);
    assert_string_equal(m.channel, "AB");
    assert_int_equal(m.channel_len, 2);
    assert_ptr_equal(m.data, lc02 + 11);
    assert_int_equal(m.len, 3);
    /* an empty payload is a message too */
    assert_int_equal(dkf_wire_parse(lc02, 11, &m), DKF_WIRE_OK);
    assert_int_equal(m.len, 0);
}

static void test_pack_writes_lcm_bytes(void **state)
{
    unsigned char out[64];
    (void)state;
    assert_int_equal(dkf_wire_pack(out, sizeof out, 0x01020304u, "AB", "xyz", 3), sizeof lc02);
    assert_memory_equal(out, lc02, sizeof lc02);
    /* exactly the room needed is enough, one byte less is not */
    assert_int_equal(dkf_wire_pack(out, sizeof lc02, 0x01020304u, "AB", "xyz", 3), sizeof lc02);
    assert_int_equal(dkf_wire_pack(out, sizeof lc02 - 1, 0x01020304u, "AB", "xyz", 3), 0);
}

/* Channels of 1 and 63 bytes (LCM's limit) are read; 64 is not. */
static void test_channel_length_limits(void **state)
{
    static unsigned char d[8 + 65 + 4];
    char ch[65];
    dkf_wire_msg_t m;
    size_t len;
    (void)state;
    memset(ch, 'c', sizeof ch);
    ch[63] = '\0';
    len = dkf_wire_pack(d, sizeof d, 5, ch, "pq", 2);
    assert_int_equal(len, 8 + 63 + 1 + 2);
    assert_int_equal(dkf_wire_parse(d, len, &m), DKF_WIRE_OK);
    assert_int_equal(m.channel_len, 63);
    assert_memory_equal(m.data, "pq", 2);
    ch[64] = '\0';
    ch[63] = 'c';
    assert_int_equal(dkf_wire_pack(d, sizeof d, 5, ch, "pq", 2), 0);
    memcpy(d + 8, ch, 65); /* 64 bytes of channel, then its NUL */
    assert_int_equal(dkf_wire_parse(d, 8 + 65, &m), DKF_WIRE_BAD);
    assert_int_equal(dkf_wire_pack(d, sizeof d, 5, "", "pq", 2), 0);
    assert_int_equal(dkf_wire_pack(d, sizeof d, 5, "c", "pq", 2), 8 + 2 + 2);
}

static void test_refuses_malformed_untouched(void **state)
{
    static const unsigned char magic_1[] = {0x4c, 0x43, 0x30, 0x31, 0, 0, 0, 0, 'A', 0};
    static const unsigned char no_nul[] = {0x4c, 0x43, 0x30, 0x32, 0, 0, 0, 0, 'A', 'B'};
    static const unsigned char empty[] = {0x4c, 0x43, 0x30, 0x32, 0, 0, 0, 0, 0, 'x'};
    static const unsigned char header_only[] = {0x4c, 0x43, 0x30, 0x32, 0, 0, 0, 0};
    static const struct {
        const unsigned char *d;
        size_t len;
    } bad[] = {{lc02, 0}, {lc02, 7}, {magic_1, sizeof magic_1}, {no_nul, sizeof no_nul},
               {empty, sizeof empty}, {header_only, sizeof header_only}};
    dkf_wire_msg_t m, before;
    size_t i;
    (void)state;
    memset(&before, 0x5a, sizeof before);
    for (i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        m = before;
        assert_int_equal(dkf_wire_parse(bad[i].d, bad[i].len, &m), DKF_WIRE_BAD);
        assert_memory_equal(&m, &before, sizeof m);
    }
}

static void test_fragment_told_apart(void **state)
{
    /* "LC03" | seqno | size 100000 | offset 0 | fragment 0 of 2 | channel ... */
    static const unsigned char lc03[] = {0x4c, 0x43, 0x30, 0x33, 0, 0, 0, 9, 0, 1, 0x86, 0xa0,
                                         0, 0, 0, 0, 0, 0, 0, 2, 'A', 0, 'z'};
    dkf_wire_msg_t m, before;
    (void)state;
    memset(&before, 0x5a, sizeof before);
    m = before;
    assert_int_equal(dkf_wire_parse(lc03, sizeof lc03, &m), DKF_WIRE_FRAGMENT);
    assert_memory_equal(&m, &before, sizeof m);
}

/* The largest payload pack writes, and one byte more refused. */
static void test_pack_size_limit(void **state)
{
    static unsigned char d[DKF_WIRE_MAX_DATAGRAM + 16], body[DKF_WIRE_MAX_DATAGRAM];
    const size_t most = DKF_WIRE_MAX_DATAGRAM - 8 - 2 - 1;
    dkf_wire_msg_t m;
    (void)state;
    assert_int_equal(dkf_wire_pack(d, sizeof d, 1, "AB", body, most), DKF_WIRE_MAX_DATAGRAM);
    assert_int_equal(dkf_wire_pack(d, sizeof d, 1, "AB", body, most + 1), 0);
    assert_int_equal(dkf_wire_parse(d, DKF_WIRE_MAX_DATAGRAM, &m), DKF_WIRE_OK);
    assert_int_equal(m.len, most);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reads_lcm_short_datagram),
        cmocka_unit_test(test_pack_writes_lcm_bytes),
        cmocka_unit_test(test_channel_length_limits),
        cmocka_unit_test(test_refuses_malformed_untouched),
        cmocka_unit_test(test_fragment_told_apart),
        cmocka_unit_test(test_pack_size_limit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
