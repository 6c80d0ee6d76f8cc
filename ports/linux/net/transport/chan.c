/*
 * chan.c - channel names of the DKF network (chan.h): the writers and the
 * one parser every receiver and the authentication use.
 */
#include "chan.h"

#include <stdio.h>
#include <string.h>

/* 1 if s[0..len-1] is a canonical id ("0" or [1-9][0-9]{0,4}); its value in *id. */
static int canonical_id(const char *s, size_t len, long *id)
{
    size_t i;
    long v = 0;
    if (len == 0 || len > 5 || (s[0] == '0' && len > 1)) return 0;
    for (i = 0; i < len; ++i) {
        if (s[i] < '0' || s[i] > '9') return 0;
        v = v * 10 + (s[i] - '0');
    }
    *id = v;
    return 1;
}

/* 1 if ch[0..end-1] ends with "_<word>" after at least one character. */
static int ends_with_word(const char *ch, size_t end, const char *word)
{
    const size_t w = strlen(word);
    return end >= w + 2 && ch[end - w - 1] == '_' && memcmp(ch + end - w, word, w) == 0;
}

dkf_net_chan_id_t dkf_net_chan_parse(const char *channel)
{
    static const struct {
        const char *word;
        dkf_net_chan_kind_t kind;
    } named[] = {{"FUSED", DKF_CHAN_FUSED}, {"TRUTH", DKF_CHAN_TRUTH}, {"STATUS", DKF_CHAN_STATUS}};
    dkf_net_chan_id_t r = {DKF_CHAN_NONE, -1};
    const char *us;
    size_t len, head, i;
    long id;
    if (channel == NULL || (us = strrchr(channel, '_')) == NULL || us == channel) return r;
    len = strlen(channel);
    head = (size_t)(us - channel); /* the name before the last '_' */
    for (i = 0; i < sizeof named / sizeof named[0]; ++i)
        if (strcmp(us + 1, named[i].word) == 0) {
            r.kind = named[i].kind;
            return r;
        }
    if (!canonical_id(us + 1, len - head - 1, &id)) return r;
    r.id = id;
    r.kind = ends_with_word(channel, head, "NODE")   ? DKF_CHAN_NODE
             : ends_with_word(channel, head, "MEAS") ? DKF_CHAN_MEAS
                                                     : DKF_CHAN_GRAPH;
    return r;
}

long dkf_net_chan_node_id(const char *channel)
{
    const dkf_net_chan_id_t c = dkf_net_chan_parse(channel);
    return c.kind == DKF_CHAN_NODE ? c.id : -1;
}

long dkf_net_from_node(const dkf_net_from_t *from, const char *channel)
{
    if (from != NULL && from->known) return from->role == DKF_NET_ROLE_NODE ? from->id : -1;
    return dkf_net_chan_node_id(channel);
}

void dkf_net_chan_meas(char *out, const char *prefix, size_t node)
{
    snprintf(out, DKF_NET_CHAN_LEN, "%s_MEAS_%zu", prefix, node);
}

void dkf_net_chan_node(char *out, const char *prefix, size_t node)
{
    snprintf(out, DKF_NET_CHAN_LEN, "%s_NODE_%zu", prefix, node);
}

void dkf_net_chan(char *out, const char *prefix, const char *what)
{
    snprintf(out, DKF_NET_CHAN_LEN, "%s_%s", prefix, what);
}

int dkf_net_from_is(const dkf_net_from_t *from, int role, long id)
{
    return from == NULL || !from->known || (from->role == role && from->id == id);
}
