/* Interrupt-driven UART 0 (see uart.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "config.h"
#include "irq.h"
#include "ticks.h"
#include "uart.h"

/* double speed (U2X): UBRR = F_CPU / (8 * BAUD) - 1, rounded */
#define UBRR_VALUE (((F_CPU) + 4UL * (BAUD)) / (8UL * (BAUD)) - 1UL)

volatile uint8_t uart_rx_buf[UART_RX_SIZE];
volatile uint8_t uart_rx_head;
volatile uint8_t uart_rx_tail;

/* The arrival of each sync byte: its ring position and the low 16 bits of the tick
 * (timer 1's counter); the main loop, which takes the frame within a counter wrap
 * (4 ms), makes the full tick of it.  A power of two entries. */
#define SYNC_STAMPS 8
static volatile uint8_t stamp_pos[SYNC_STAMPS];
static volatile uint16_t stamp_tick[SYNC_STAMPS];
static volatile uint8_t stamp_next;

static volatile uint8_t tx_buf[UART_TX_SIZE];
static volatile uint8_t tx_head;  /* main loop */
static volatile uint8_t tx_tail;  /* interrupt */

volatile uint16_t uart_rx_overruns;

void uart_init(void)
{
    /* U2X before the rate: simavr computes its character time when UBRR is written */
    UCSR0A = _BV(U2X0);
    UBRR0H = (uint8_t)(UBRR_VALUE >> 8);
    UBRR0L = (uint8_t)UBRR_VALUE;
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);  /* 8N1 */
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

#define K_(x) #x
#define K(x) K_(x)

/* The receive interrupt, in assembly: it comes for every byte (every 160 cycles at
 * 1 000 000 baud), so it saves five registers, not the seventeen of a C routine
 * with a 32-bit stamp.  What it does:
 *     main_wake |= WAKE_RX; status = UCSR0A; b = UDR0;
 *     if (status & (DOR0 | FE0)) uart_rx_overruns++;
 *     if (ring full) { uart_rx_overruns++; return; }
 *     uart_rx_buf[uart_rx_head % UART_RX_SIZE] = b; uart_rx_head++;
 *     if (b == 0x7E) { stamp_pos[n] = old head; stamp_tick[n] = TCNT1; n = (n+1) % 8; } */
ISR(USART_RX_vect, ISR_NAKED)
{
    __asm__ __volatile__(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
        "push r25\n\t"
        "push r30\n\t"
        "push r31\n\t"
        "lds r24, %[wake]\n\t"
        "ori r24, " K(WAKE_RX) "\n\t"
        "sts %[wake], r24\n\t"
        "lds r25, %[ucsra]\n\t"
        "lds r24, %[udr]\n\t"
        "andi r25, " K(_BV(DOR0) | _BV(FE0)) "\n\t"
        "breq 1f\n\t"
        "rcall 8f\n"                           /* a byte was lost or damaged: count it */
        "1:\n\t"
        "lds r30, %[head]\n\t"
        "lds r25, %[tail]\n\t"
        "mov r31, r30\n\t"
        "sub r31, r25\n\t"
        "cpi r31, " K(UART_RX_SIZE) "\n\t"
        "brlo 2f\n\t"
        "rcall 8f\n\t"                         /* the ring is full: the byte is lost */
        "rjmp 9f\n"
        "2:\n\t"
        "mov r25, r30\n\t"                     /* r25: the byte's ring position */
        "inc r30\n\t"
        "sts %[head], r30\n\t"
        "mov r30, r25\n\t"
        "andi r30, " K(UART_RX_SIZE - 1) "\n\t"
        "ldi r31, 0\n\t"
        "subi r30, lo8(-(%[buf]))\n\t"
        "sbci r31, hi8(-(%[buf]))\n\t"
        "st Z, r24\n\t"
        "cpi r24, " K(UART_SYNC_BYTE) "\n\t"
        "brne 9f\n\t"
        /* a sync byte: note where and when */
        "lds r24, %[next]\n\t"
        "mov r30, r24\n\t"
        "ldi r31, 0\n\t"
        "subi r30, lo8(-(%[pos]))\n\t"
        "sbci r31, hi8(-(%[pos]))\n\t"
        "st Z, r25\n\t"
        "mov r30, r24\n\t"
        "lsl r30\n\t"
        "ldi r31, 0\n\t"
        "subi r30, lo8(-(%[tick]))\n\t"
        "sbci r31, hi8(-(%[tick]))\n\t"
        "lds r25, %[tcnt]\n\t"
        "st Z+, r25\n\t"
        "lds r25, %[tcnt]+1\n\t"
        "st Z, r25\n\t"
        "inc r24\n\t"
        "andi r24, " K(SYNC_STAMPS - 1) "\n\t"
        "sts %[next], r24\n"
        "9:\n\t"
        "pop r31\n\t"
        "pop r30\n\t"
        "pop r25\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti\n"
        "8:\n\t"                               /* uart_rx_overruns++ (r30, r31) */
        "lds r30, %[overruns]\n\t"
        "lds r31, %[overruns]+1\n\t"
        "adiw r30, 1\n\t"
        "sts %[overruns]+1, r31\n\t"
        "sts %[overruns], r30\n\t"
        "ret\n\t"
        :: [wake] "i"(&main_wake), [ucsra] "i"(_SFR_MEM_ADDR(UCSR0A)),
           [udr] "i"(_SFR_MEM_ADDR(UDR0)), [head] "i"(&uart_rx_head),
           [tail] "i"(&uart_rx_tail), [buf] "i"(&uart_rx_buf[0]), [next] "i"(&stamp_next), [pos] "i"(&stamp_pos[0]),
           [tick] "i"(&stamp_tick[0]), [tcnt] "i"(_SFR_MEM_ADDR(TCNT1)),
           [overruns] "i"(&uart_rx_overruns));
}

uint32_t uart_rx_sync_tick(uint8_t offset)
{
    uint8_t pos = uart_rx_tail + offset;
    uint8_t s = stamp_next;
    uint32_t now = ticks_now();
    for (uint8_t i = 0; i < SYNC_STAMPS; i++) {
        s = (s - 1) & (SYNC_STAMPS - 1);
        uint8_t p;
        uint16_t t;
        uint8_t sreg = irq_save();
        p = stamp_pos[s];
        t = stamp_tick[s];
        irq_restore(sreg);
        if (p == pos)
            return now - (uint16_t)((uint16_t)now - t);  /* less than a counter wrap ago */
    }
    return now;
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
