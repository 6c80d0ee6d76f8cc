/*
 * live_frames.h - the words of the live node image's frames, shared by the
 * image (live_main.c, whose comment lays the frames out) and the host
 * program that feeds it (ports/linux/net/agents/m4_node.c, dkf-m4-bridge).
 */
#ifndef M4_LIVE_FRAMES_H
#define M4_LIVE_FRAMES_H

#define LV_MAGIC_IN 0x314C4B44u  /* "DKL1": the header, host to image */
#define LV_MAGIC_OUT 0x314D4B44u /* "DKM1": every answer, image to host */

/* host to image: a frame's kind */
#define LV_IN_START 1u
#define LV_IN_STEP 2u
#define LV_IN_END 3u

/* image to host: an answer's kind */
#define LV_OUT_READY 0u
#define LV_OUT_STARTED 1u
#define LV_OUT_MSG 2u
#define LV_OUT_REFUSED 3u
#define LV_OUT_BYE 4u

/* the named pipes, in QEMU's working directory */
#define LV_PIPE_IN "m4_live.in"
#define LV_PIPE_OUT "m4_live.out"

#endif /* M4_LIVE_FRAMES_H */
