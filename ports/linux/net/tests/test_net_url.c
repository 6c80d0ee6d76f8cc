/*
 * LCM URL safety (net.h): only memq:// and udpm:// to a 239.0.0.0/8 group
 * with ttl=0 (exactly once) are accepted, in every scope; with --lan (scope
 * DKF_NET_LAN) LCM opens that URL with ttl=1; dkf_net_open refuses the rest
 * before LCM is touched.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "net.h"

static void test_accepts_safe_urls(void **state)
{
    static const char *const ok[] = {
        DKF_NET_DEFAULT_URL,
        "memq://",
        "udpm://239.255.76.67:7667?ttl=0",
        "udpm://239.0.0.1:1?ttl=0",
        "udpm://239.1.2.3?ttl=0",
        "udpm://239.255.76.67:7667?recv_buf_size=2097152&ttl=0",
        "udpm://239.255.76.67:65535?ttl=0&recv_buf_size=100000",
    };
    char err[DKF_NET_ERR_LEN];
    size_t i;
    (void)state;
    for (i = 0; i < sizeof ok / sizeof ok[0]; ++i) {
        err[0] = '\0';
        if (dkf_net_check_url(ok[i], err, sizeof err) != 0) fail_msg("%s refused: %s", ok[i], err);
    }
}

static void test_refuses_unsafe_urls(void **state)
{
    static const struct {
        const char *url, *why;
    } bad[] = {
        {"udpm://239.255.76.67:7667", "ttl=0 exactly once"},          /* LCM's default ttl */
        {"udpm://239.255.76.67:7667?ttl=1", "ttl must be 0"},
        {"udpm://239.255.76.67:7667?ttl=00", "ttl must be 0"},
        {"udpm://239.255.76.67:7667?ttl=", "ttl must be 0"},
        {"udpm://239.255.76.67:7667?ttl=0&ttl=1", "ttl must be 0"},
        {"udpm://239.255.76.67:7667?ttl=0&ttl=0", "ttl=0 exactly once"},
        {"udpm://239.255.76.67:7667?xttl=0", "ttl=0 exactly once"},
        {"udpm://224.0.0.1:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://238.255.76.67:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://240.0.0.1:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://10.0.0.1:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://127.0.0.1:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://239.256.0.1:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://239.1.2:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://239.1.2.3.4:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://239.1.2.-3:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://0239.1.2.3:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://?ttl=0", "239.0.0.0/8"},
        {"udpm://host.example:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://239.255.76.67:0?ttl=0", "bad port"},
        {"udpm://239.255.76.67:07667?ttl=0", "bad port"},
        {"udpm://239.255.76.67:70000?ttl=0", "bad port"},
        {"udpm://239.255.76.67:76a?ttl=0", "bad port"},
        {"udpm://239.255.76.67:?ttl=0", "bad port"},
        {"udp://239.255.76.67:7667?ttl=0", "only udpm"},
        {"tcpq://127.0.0.1:7700", "only udpm"},
        {"file:///tmp/x.log?mode=w", "only udpm"},
        {"memq://x", "only udpm"},
        {"", "only udpm"},
        {"UDPM://239.255.76.67:7667?ttl=0", "only udpm"},
    };
    char err[DKF_NET_ERR_LEN];
    size_t i;
    (void)state;
    for (i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        err[0] = '\0';
        if (dkf_net_check_url(bad[i].url, err, sizeof err) == 0)
            fail_msg("%s accepted", bad[i].url);
        if (strstr(err, bad[i].why) == NULL)
            fail_msg("%s: message '%s' lacks '%s'", bad[i].url, err, bad[i].why);
        /* the message is one line naming the URL */
        assert_null(strchr(err, '\n'));
        assert_non_null(strstr(err, bad[i].url));
    }
    assert_int_equal(dkf_net_check_url(NULL, err, sizeof err), -1);
}

/* dkf_net_open applies the same check (no LCM instance is created). */
static void test_open_refuses(void **state)
{
    char err[DKF_NET_ERR_LEN] = "";
    (void)state;
    assert_null(dkf_net_open("udpm://239.255.76.67:7667?ttl=1", err, sizeof err));
    assert_non_null(strstr(err, "ttl must be 0"));
    assert_null(dkf_net_open("udpm://224.1.1.1:7667?ttl=0", err, sizeof err));
    assert_non_null(strstr(err, "239.0.0.0/8"));
}

/* Scope DKF_NET_LAN (--lan): the URLs and refusals of scope DKF_NET_HOST
 * (a URL never says more than ttl=0, with or without --lan); LCM is given
 * the URL with ttl=1 in scope DKF_NET_LAN, unchanged in DKF_NET_HOST. */
static void test_lan_scope(void **state)
{
    static const struct {
        const char *url, *lan;
    } ok[] = {
        {"udpm://239.255.76.67:7667?ttl=0", "udpm://239.255.76.67:7667?ttl=1"},
        {"udpm://239.1.2.3?recv_buf_size=2097152&ttl=0",
         "udpm://239.1.2.3?recv_buf_size=2097152&ttl=1"},
        {"udpm://239.1.2.3?ttl=0&recv_buf_size=100000", "udpm://239.1.2.3?ttl=1&recv_buf_size=100000"},
        {"memq://", "memq://"},
    };
    static const struct {
        const char *url, *why;
    } bad[] = {
        {"udpm://239.255.76.67:7667?ttl=1", "ttl must be 0 ("},
        {"udpm://239.255.76.67:7667?ttl=2", "ttl must be 0 ("},
        {"udpm://239.255.76.67:7667?ttl=255", "ttl must be 0 ("},
        {"udpm://239.255.76.67:7667?ttl=01", "ttl must be 0 ("},
        {"udpm://239.255.76.67:7667?ttl=", "ttl must be 0 ("},
        {"udpm://239.255.76.67:7667?ttl=0&ttl=1", "ttl must be 0 ("},
        {"udpm://239.255.76.67:7667?ttl=0&ttl=0", "exactly once"},
        {"udpm://239.255.76.67:7667", "exactly once"},
        {"udpm://224.0.0.1:7667?ttl=0", "239.0.0.0/8"},
        {"udpm://239.255.76.67:0?ttl=0", "bad port"},
        {"tcpq://127.0.0.1:7700", "only udpm"},
    };
    char err[DKF_NET_ERR_LEN], out[128];
    size_t i;
    int scope;
    (void)state;
    for (i = 0; i < sizeof ok / sizeof ok[0]; ++i) {
        err[0] = '\0';
        if (dkf_net_lcm_url(ok[i].url, DKF_NET_LAN, out, sizeof out, err, sizeof err) != 0)
            fail_msg("--lan: %s refused: %s", ok[i].url, err);
        assert_string_equal(out, ok[i].lan);
        assert_int_equal(dkf_net_lcm_url(ok[i].url, DKF_NET_HOST, out, sizeof out, err,
                                         sizeof err), 0);
        assert_string_equal(out, ok[i].url);
    }
    for (scope = DKF_NET_HOST; scope <= DKF_NET_LAN; ++scope)
        for (i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
            err[0] = '\0';
            if (dkf_net_check_url_scope(bad[i].url, scope, err, sizeof err) == 0)
                fail_msg("scope %d: %s accepted", scope, bad[i].url);
            if (strstr(err, bad[i].why) == NULL)
                fail_msg("scope %d: %s: message '%s' lacks '%s'", scope, bad[i].url, err,
                         bad[i].why);
            assert_null(strchr(err, '\n'));
            assert_non_null(strstr(err, bad[i].url));
            assert_int_equal(dkf_net_lcm_url(bad[i].url, scope, out, sizeof out, err, sizeof err),
                             -1);
        }
    /* a ttl other than 0 names the way to several hosts */
    assert_int_equal(dkf_net_check_url(bad[0].url, err, sizeof err), -1);
    assert_non_null(strstr(err, "--lan"));
    /* too long for the output, no other scope */
    assert_int_equal(dkf_net_lcm_url(ok[0].url, DKF_NET_LAN, out, 10, err, sizeof err), -1);
    assert_int_equal(dkf_net_check_url_scope(ok[0].url, 2, err, sizeof err), -1);
    assert_non_null(strstr(err, "scope"));
    assert_int_equal(dkf_net_check_url_scope(ok[0].url, -1, err, sizeof err), -1);
    assert_int_equal(dkf_net_check_url_scope(NULL, DKF_NET_LAN, err, sizeof err), -1);
}

/* dkf_net_open_scope applies the check in either scope (no LCM instance is
 * created for a refused URL); memq:// opens in either. */
static void test_open_scope(void **state)
{
    char err[DKF_NET_ERR_LEN] = "";
    dkf_net_t *net;
    (void)state;
    assert_null(dkf_net_open_scope("udpm://239.255.76.67:7667?ttl=1", DKF_NET_LAN, err, sizeof err));
    assert_non_null(strstr(err, "ttl must be 0 ("));
    assert_null(dkf_net_open_scope("udpm://239.255.76.67:7667?ttl=1", DKF_NET_HOST, err,
                                   sizeof err));
    assert_non_null(strstr(err, "ttl must be 0 ("));
    net = dkf_net_open_scope("memq://", DKF_NET_LAN, err, sizeof err);
    assert_non_null(net);
    dkf_net_close(net);
}

/* memq:// opens, and a message published is delivered to a subscriber. */
static int got;
static void on_msg(const char *channel, const dkf_net_from_t *from, const void *data, size_t len,
                   int64_t t, void *user)
{
    (void)t;
    (void)user;
    assert_false(from->known); /* no authentication: no sender */
    assert_string_equal(channel, "DKF_TEST");
    assert_int_equal(len, 3);
    assert_memory_equal(data, "abc", 3);
    ++got;
}

static void test_memq_round_trip(void **state)
{
    char err[DKF_NET_ERR_LEN] = "";
    dkf_net_t *net = dkf_net_open("memq://", err, sizeof err);
    (void)state;
    assert_non_null(net);
    assert_int_equal(dkf_net_subscribe(net, "DKF_TEST", on_msg, NULL), 0);
    assert_int_equal(dkf_net_publish(net, "DKF_TEST", "abc", 3), 0);
    assert_int_equal(dkf_net_publish(net, "OTHER", "xyz", 3), 0);
    /* memq may drop a message nobody subscribed to before queueing it */
    assert_true(dkf_net_drain(net, 100) >= 1);
    assert_int_equal(got, 1);
    assert_int_equal(dkf_net_handle(net, 0), 0);
    dkf_net_close(net);
}

/* The test clock offset (--clock-offset-ms): dkf_net_now_us and the receive
 * times a handler gets move by it together; the monotonic clock does not. */
static int64_t got_utime;
static void on_stamp(const char *channel, const dkf_net_from_t *from, const void *data,
                     size_t len, int64_t t, void *user)
{
    (void)channel;
    (void)from;
    (void)data;
    (void)len;
    (void)user;
    got_utime = t;
}

static void test_clock_offset(void **state)
{
    const int64_t off = 1000000000000; /* 11.6 days */
    char err[DKF_NET_ERR_LEN] = "";
    dkf_net_t *net = dkf_net_open("memq://", err, sizeof err);
    int64_t before, after, m0;
    (void)state;
    assert_non_null(net);
    assert_int_equal(dkf_net_clock_offset_us(), 0);
    assert_int_equal(dkf_net_subscribe(net, "DKF_TEST", on_stamp, NULL), 0);
    before = dkf_net_now_us();
    m0 = dkf_net_mono_us();
    dkf_net_clock_set_offset_us(off);
    assert_int_equal(dkf_net_clock_offset_us(), off);
    assert_true(dkf_net_mono_us() - m0 < off / 2);
    assert_int_equal(dkf_net_publish(net, "DKF_TEST", "abc", 3), 0);
    assert_int_equal(dkf_net_drain(net, 100), 1);
    after = dkf_net_now_us();
    assert_true(got_utime >= before + off);
    assert_true(got_utime <= after);
    dkf_net_clock_set_offset_us(0);
    assert_true(dkf_net_now_us() < after - off / 2);
    dkf_net_close(net);
}

/* Split ports and direct receive need a udpm URL (their tests over sockets
 * are the namespace tests net_udpm_ex3_split and _direct): memq is refused,
 * and nothing changes for it. */
static void test_split_needs_udpm(void **state)
{
    char err[DKF_NET_ERR_LEN] = "";
    dkf_net_t *net = dkf_net_open("memq://", err, sizeof err);
    (void)state;
    assert_non_null(net);
    assert_int_equal(dkf_net_split(net, err, sizeof err), -1);
    assert_non_null(strstr(err, "udpm"));
    err[0] = '\0';
    assert_int_equal(dkf_net_direct(net, err, sizeof err), -1); /* the same for direct receive */
    assert_non_null(strstr(err, "udpm"));
    assert_int_equal(dkf_net_rx(net).direct, 0);
    got = 0;
    assert_int_equal(dkf_net_subscribe(net, "DKF_TEST", on_msg, NULL), 0);
    assert_int_equal(dkf_net_publish(net, "DKF_TEST", "abc", 3), 0);
    assert_true(dkf_net_drain(net, 100) >= 1);
    assert_int_equal(got, 1);
    dkf_net_close(net);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_accepts_safe_urls),
        cmocka_unit_test(test_refuses_unsafe_urls),
        cmocka_unit_test(test_open_refuses),
        cmocka_unit_test(test_lan_scope),
        cmocka_unit_test(test_open_scope),
        cmocka_unit_test(test_memq_round_trip),
        cmocka_unit_test(test_clock_offset),
        cmocka_unit_test(test_split_needs_udpm),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
