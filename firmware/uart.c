/* Interrupt-driven UART 0 (see uart.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "config.h"
#include "irq.h"
#include "ticks.h"
#include "uart.h"

/* double speed (U2X): UBRR = F_CPU / (8 * BAUD) - 1, rounded */
#define UBRR_VALUE (((F_CPU) + 4UL * (BAUD)) / (8UL * (BAUD)) - 1UL)

static volatile uint8_t rx_buf[UART_RX_SIZE];
static volatile uint8_t rx_head;  /* written by the interrupt; indices run mod 256 */
static uint8_t rx_tail;           /* main loop */

#define SYNC_STAMPS 8             /* a power of two */
static volatile uint8_t stamp_pos[SYNC_STAMPS];
static volatile uint32_t stamp_tick[SYNC_STAMPS];
static volatile uint8_t stamp_next;

static volatile uint8_t tx_buf[UART_TX_SIZE];
static volatile uint8_t tx_head;  /* main loop */
static volatile uint8_t tx_tail;  /* interrupt */

volatile uint16_t uart_rx_overruns;
volatile uint16_t uart_rx_bad_bits;

void uart_init(void)
{
    /* U2X before the rate: simavr computes its character time when UBRR is written */
    UCSR0A = _BV(U2X0);
    UBRR0H = (uint8_t)(UBRR_VALUE >> 8);
    UBRR0L = (uint8_t)UBRR_VALUE;
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);  /* 8N1 */
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

ISR(USART_RX_vect)
{
    main_wake |= WAKE_RX;
    uint8_t status = UCSR0A;
    uint8_t b = UDR0;
    if (status & _BV(DOR0))
        uart_rx_overruns++;
    if (status & _BV(FE0))
        uart_rx_bad_bits++;
    uint8_t head = rx_head;
    if ((uint8_t)(head - rx_tail) >= UART_RX_SIZE) {
        uart_rx_overruns++;
        return;
    }
    rx_buf[head % UART_RX_SIZE] = b;
    rx_head = head + 1;
    if (b == UART_SYNC_BYTE) {
        uint8_t s = stamp_next;
        stamp_pos[s] = head;
        stamp_tick[s] = ticks_now();
        stamp_next = (s + 1) & (SYNC_STAMPS - 1);
    }
}

uint8_t uart_rx_count(void)
{
    return (uint8_t)(rx_head - rx_tail);
}

uint8_t uart_rx_peek(uint8_t offset)
{
    return rx_buf[(uint8_t)(rx_tail + offset) % UART_RX_SIZE];
}

void uart_rx_drop(uint8_t n)
{
    rx_tail += n;
}

uint32_t uart_rx_sync_tick(uint8_t offset)
{
    uint8_t pos = rx_tail + offset;
    uint8_t s = stamp_next;
    for (uint8_t i = 0; i < SYNC_STAMPS; i++) {
        s = (s - 1) & (SYNC_STAMPS - 1);
        uint8_t p;
        uint32_t t;
        uint8_t sreg = irq_save();
        p = stamp_pos[s];
        t = stamp_tick[s];
        irq_restore(sreg);
        if (p == pos)
            return t;
    }
    return ticks_now();
}

volatile uint8_t uart_tx_waiting;

ISR(USART_UDRE_vect)
{
    if (uart_tx_waiting)
        main_wake |= WAKE_TX;  /* room in the ring for the output that waits */
    uint8_t tail = tx_tail;
    if (tail == tx_head) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UDR0 = tx_buf[tail % UART_TX_SIZE];
    tx_tail = tail + 1;
}

uint8_t uart_tx_free(void)
{
    return (uint8_t)(UART_TX_SIZE - (uint8_t)(tx_head - tx_tail));
}

void uart_tx_put(uint8_t b)
{
    uint8_t head = tx_head;
    tx_buf[head % UART_TX_SIZE] = b;
    tx_head = head + 1;
    uint8_t sreg = irq_save();  /* UCSR0B is out of reach of sbi: a read-modify-write */
    UCSR0B |= _BV(UDRIE0);      /* the transmit interrupt shares */
    irq_restore(sreg);
}

uint8_t uart_tx_idle(void)
{
    return tx_head == tx_tail && (UCSR0A & _BV(UDRE0));
}
