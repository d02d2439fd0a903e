/* Frames of docs/serial-protocol.md section 2: LEN SEQ PAYLOAD CRC_HI CRC_LO 0x7E,
 * CRC-16/CCITT-FALSE over LEN SEQ PAYLOAD. */
#ifndef FW_FRAME_H
#define FW_FRAME_H

#include <stdint.h>

#define FRAME_OVERHEAD 5
#define FRAME_MAX 64
#define FRAME_MAX_PAYLOAD (FRAME_MAX - FRAME_OVERHEAD)
#define FRAME_SYNC 0x7E

struct frame_in {
    uint8_t seq;
    uint8_t len;      /* payload bytes */
    uint32_t tick;    /* arrival of the frame's last byte */
    uint8_t payload[FRAME_MAX_PAYLOAD];
};

/* Take the next valid frame from the receive ring (1) or say none is complete (0).
 * Rejected bytes are counted and skipped up to and including the next sync byte. */
uint8_t frame_receive(struct frame_in *f);
extern uint16_t frame_crc_errors;
extern uint16_t frame_framing_errors;
void frame_reset_counters(void);

uint16_t frame_crc(uint16_t crc, uint8_t b);

/* Queue one frame for sending; 0 (nothing written) when the transmit ring lacks room. */
uint8_t frame_send(uint8_t seq, const uint8_t *payload, uint8_t len);

#endif
