/* Device firmware for the serial backend of stepperdemo (docs/serial-protocol.md):
 * the host plans the motion; this chip executes the queue commands with timer 1 and
 * reports back.  ATmega328P at 16 MHz (Arduino Uno/Nano), steppers on pins 9 and 10.
 *
 * Interrupts: timer 1 compare A/B (steps, stepgen.c), timer 1 overflow (the tick
 * counter, ticks.c), UART receive and transmit (uart.c), timer 0 overflow (a wake-up
 * every 1.024 ms for the periodic reports).  The main loop decodes frames, acts on
 * them, sends reports, and sleeps (idle mode) when there is nothing to do.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "frame.h"
#include "irq.h"
#include "session.h"
#include "stepgen.h"
#include "ticks.h"
#include "uart.h"

/* Timer 0: prescaler 64, overflow every 16384 cycles.  Its only job is to end the
 * idle sleep, so that the reports go out on time. */
EMPTY_INTERRUPT(TIMER0_OVF_vect);

static void wake_tick_init(void)
{
    TCCR0A = 0;
    TCCR0B = _BV(CS01) | _BV(CS00);
    TIMSK0 = _BV(TOIE0);
}

int main(void)
{
    static struct frame_in frame;

    ticks_init();
    stepgen_init();
    uart_init();
    wake_tick_init();
    set_sleep_mode(SLEEP_MODE_IDLE);
    irq_on();
    session_init();
    for (;;) {
        while (frame_receive(&frame))
            session_frame(&frame);
        uint8_t seen = uart_rx_count();
        stepgen_poll();
        session_poll();
        /* sleep unless a byte came meanwhile; any interrupt wakes the loop */
        cli();
        if (uart_rx_count() == seen && !session_busy()) {
            sleep_enable();
            sei();
            sleep_cpu();
            sleep_disable();
        }
        irq_on();
    }
}
