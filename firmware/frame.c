/* Frame decoding on the receive ring and frame encoding into the transmit ring. */
#include <avr/pgmspace.h>

#include "frame.h"
#include "uart.h"

uint16_t frame_crc_errors;
uint16_t frame_framing_errors;
static uint8_t resync;

/* CRC-16/CCITT (polynomial 0x1021, most significant bit first), a byte at a time from
 * a table in flash: every received byte goes through it, 100 000 a second at
 * 1 000 000 baud. */
static const uint16_t crc_table[256] PROGMEM = {
#define C1(c) ((uint16_t)(((c) & 0x8000) ? (((c) << 1) ^ 0x1021) : ((c) << 1)))
#define C8(b) C1(C1(C1(C1(C1(C1(C1(C1((uint16_t)((b) << 8)))))))))
#define R4(b) C8(b), C8((b) + 1), C8((b) + 2), C8((b) + 3)
#define R16(b) R4(b), R4((b) + 4), R4((b) + 8), R4((b) + 12)
#define R64(b) R16(b), R16((b) + 16), R16((b) + 32), R16((b) + 48)
    R64(0), R64(64), R64(128), R64(192)
};

static inline uint16_t crc_step(uint16_t crc, uint8_t b)
{
    return (uint16_t)(crc << 8) ^ pgm_read_word(&crc_table[(uint8_t)(crc >> 8) ^ b]);
}

uint16_t frame_crc(uint16_t crc, uint8_t b)
{
    return crc_step(crc, b);
}

void frame_reset_counters(void)
{
    frame_crc_errors = 0;
    frame_framing_errors = 0;
}

/* The frame being received is read in place in the receive ring, each byte once as it
 * comes (the CRC and the copy of the payload go along); it is released when complete
 * or rejected - a rejected one is resynchronised from its LEN byte. */
static uint8_t got;       /* bytes of the frame at the ring's tail looked at so far */
static uint16_t crc;

uint8_t frame_receive(struct frame_in *f)
{
    for (;;) {
        uint8_t avail = uart_rx_count();
        if (resync) {
            while (avail) {
                uint8_t b = uart_rx_peek(0);
                uart_rx_drop(1);
                avail--;
                if (b == FRAME_SYNC) {
                    resync = 0;
                    break;
                }
            }
            if (resync)
                return 0;
            continue;
        }
        if (!avail)
            return 0;
        uint8_t n = uart_rx_peek(0);
        if (n < FRAME_OVERHEAD || n > FRAME_MAX) {
            frame_framing_errors++;
            resync = 1;
            continue;
        }
        if (got == 0) {
            crc = crc_step(0xFFFF, n);
            got = 1;
        }
        /* LEN SEQ PAYLOAD are CRC'd; the payload is copied as it goes */
        uint8_t end = n - 3 < avail ? n - 3 : avail;
        uint8_t k = got;
        uint16_t c = crc;
        uint8_t pos = uart_rx_tail + k;
        while (k < end) {
            uint8_t b = uart_rx_buf[pos++ % UART_RX_SIZE];
            c = crc_step(c, b);
            if (k >= 2)
                f->payload[k - 2] = b;
            k++;
        }
        got = k;
        crc = c;
        if (avail < n)
            return 0;
        uint8_t ok = uart_rx_peek(n - 1) == FRAME_SYNC;
        got = 0;
        if (!ok) {
            frame_framing_errors++;
            resync = 1;
            continue;
        }
        if (crc != (((uint16_t)uart_rx_peek(n - 3) << 8) | uart_rx_peek(n - 2))) {
            frame_crc_errors++;
            resync = 1;
            continue;
        }
        f->seq = uart_rx_peek(1);
        f->len = n - FRAME_OVERHEAD;
        f->tick = uart_rx_sync_tick(n - 1);
        uart_rx_drop(n);
        return 1;
    }
}

uint8_t frame_send(uint8_t seq, const uint8_t *payload, uint8_t len)
{
    uint8_t n = len + FRAME_OVERHEAD;
    if (len > FRAME_MAX_PAYLOAD || uart_tx_free() < n)
        return 0;
    uint16_t crc = crc_step(0xFFFF, n);
    crc = crc_step(crc, seq);
    uart_tx_put(n);
    uart_tx_put(seq);
    for (uint8_t i = 0; i < len; i++) {
        crc = crc_step(crc, payload[i]);
        uart_tx_put(payload[i]);
    }
    uart_tx_put((uint8_t)(crc >> 8));
    uart_tx_put((uint8_t)crc);
    uart_tx_put(FRAME_SYNC);
    return 1;
}
