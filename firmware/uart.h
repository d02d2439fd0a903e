/* Interrupt-driven UART 0 (pins 0/1): 8N1 at BAUD, receive and transmit rings.
 *
 * The receive interrupt stores each byte; for every sync byte (0x7E) it also notes
 * the tick it arrived at, so that a frame's arrival time is the time of its last
 * byte (SyncReply, watchdog), however late the main loop gets to it. */
#ifndef FW_UART_H
#define FW_UART_H

#include <stdint.h>

/* Ring sizes (powers of two): the receive ring holds a whole frame (64) and what
 * arrives while it is decoded in place; the transmit ring one frame and the next. */
#define UART_RX_SIZE 128
#define UART_TX_SIZE 128
#define UART_SYNC_BYTE 0x7E

void uart_init(void);
/* Why the main loop should look around (bits), set by interrupts. */
extern volatile uint8_t main_wake;
#define WAKE_RX 0x01    /* a byte arrived */
#define WAKE_TICK 0x02  /* the 1.024 ms tick of timer 0 */
#define WAKE_TX 0x04    /* a byte left while output waits for room */
#define WAKE_IDLE 0x08  /* a queue ran dry (synchronized outputs wait for that) */
#define WAKE_INPUT 0x10 /* a watched or limit pin changed (pin-change interrupt) */
#define WAKE_LIMIT 0x20 /* a limit switch stopped a queue */
/* set by the sender while output waits for room in the transmit ring */
extern volatile uint8_t uart_tx_waiting;

/* receiving: bytes are read in place, then released (inline: every byte is read
 * once at 1 000 000 baud) */
extern volatile uint8_t uart_rx_buf[UART_RX_SIZE];
extern volatile uint8_t uart_rx_head;  /* written by the interrupt; indices run mod 256 */
extern volatile uint8_t uart_rx_tail;  /* main loop */

static inline uint8_t uart_rx_count(void)
{
    return (uint8_t)(uart_rx_head - uart_rx_tail);
}

/* the byte `offset` after the oldest unread one */
static inline uint8_t uart_rx_peek(uint8_t offset)
{
    return uart_rx_buf[(uint8_t)(uart_rx_tail + offset) % UART_RX_SIZE];
}

static inline void uart_rx_drop(uint8_t n)
{
    uart_rx_tail += n;
}
/* The tick at which the sync byte at `offset` arrived (or now, if unknown). */
uint32_t uart_rx_sync_tick(uint8_t offset);
/* bytes lost or damaged: the ring was full, the UART overran, or a stop bit was missing */
extern volatile uint16_t uart_rx_overruns;

/* transmitting */
uint8_t uart_tx_free(void);
void uart_tx_put(uint8_t b);  /* the caller checked uart_tx_free() */
uint8_t uart_tx_idle(void);   /* everything sent */

#endif
