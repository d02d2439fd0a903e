/* Frame decoding on the receive ring and frame encoding into the transmit ring. */
#include <util/crc16.h>

#include "frame.h"
#include "uart.h"

uint16_t frame_crc_errors;
uint16_t frame_framing_errors;
static uint8_t resync;

uint16_t frame_crc(uint16_t crc, uint8_t b)
{
    /* CCITT, most significant bit first: the XMODEM update step, here from 0xFFFF */
    return _crc_xmodem_update(crc, b);
}

void frame_reset_counters(void)
{
    frame_crc_errors = 0;
    frame_framing_errors = 0;
}

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
        if (avail < n)
            return 0;
        if (uart_rx_peek(n - 1) != FRAME_SYNC) {
            frame_framing_errors++;
            resync = 1;
            continue;
        }
        uint16_t crc = 0xFFFF;
        for (uint8_t i = 0; i < n - 3; i++)
            crc = frame_crc(crc, uart_rx_peek(i));
        uint16_t got = ((uint16_t)uart_rx_peek(n - 3) << 8) | uart_rx_peek(n - 2);
        if (crc != got) {
            frame_crc_errors++;
            resync = 1;
            continue;
        }
        f->seq = uart_rx_peek(1);
        f->len = n - FRAME_OVERHEAD;
        for (uint8_t i = 0; i < f->len; i++)
            f->payload[i] = uart_rx_peek(2 + i);
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
    uint16_t crc = frame_crc(0xFFFF, n);
    crc = frame_crc(crc, seq);
    uart_tx_put(n);
    uart_tx_put(seq);
    for (uint8_t i = 0; i < len; i++) {
        crc = frame_crc(crc, payload[i]);
        uart_tx_put(payload[i]);
    }
    uart_tx_put((uint8_t)(crc >> 8));
    uart_tx_put((uint8_t)crc);
    uart_tx_put(FRAME_SYNC);
    return 1;
}
