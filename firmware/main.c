/* Device firmware for the serial backend of stepperdemo (docs/serial-protocol.md):
 * the host plans the motion; this chip executes the queue commands with timer 1 and
 * reports back.  ATmega328P at 16 MHz (Arduino Uno/Nano), steppers on pins 9 and 10.
 *
 * Interrupts: timer 1 compare A/B (steps, stepgen.c), timer 1 overflow (the tick
 * counter, ticks.c), UART receive and transmit (uart.c), timer 0 overflow (a wake-up
 * every 1.024 ms for the periodic reports), pin change (inputs and limit switches,
 * inputs.c, limits.c).  The main loop decodes frames, acts on
 * them, sends reports, and sleeps (idle mode) when there is nothing to do.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "device.h"
#include "frame.h"
#include "inputs.h"
#include "irq.h"
#include "limits.h"
#include "outputs.h"
#include "session.h"
#include "stepgen.h"
#include "ticks.h"
#include "uart.h"

/* Why the main loop should look around: set by the UART's interrupts and by timer 0
 * (prescaler 64, an overflow every 16384 cycles, for the periodic reports).  The
 * step interrupts wake the chip too, but leave this alone: the loop sleeps again at
 * once. */
volatile uint8_t main_wake;

ISR(TIMER0_OVF_vect)
{
    main_wake |= WAKE_TICK;
}

/* The RAM between the static data and the stack is painted at reset, so that the
 * deepest the stack went can be read from the chip (bench/bench_firmware.py). */
#define STACK_PAINT 0xC5
extern uint8_t _end;
extern uint8_t __stack;
void paint_stack(void) __attribute__((naked, used, section(".init1")));
void paint_stack(void)
{
    __asm__ __volatile__(
        "ldi r30, lo8(_end)\n\t"
        "ldi r31, hi8(_end)\n\t"
        "ldi r24, %[paint]\n\t"
        "ldi r25, hi8(__stack)\n\t"
        "1:\n\t"
        "st Z+, r24\n\t"
        "cpi r30, lo8(__stack)\n\t"
        "cpc r31, r25\n\t"
        "brlo 1b\n\t"
        "breq 1b\n\t"
        :: [paint] "i"(STACK_PAINT));
}

int main(void)
{
    static struct frame_in frame;

    ticks_init();
    stepgen_init();
    uart_init();
    outputs_init();  /* timer 0: PWM and the 1 ms tick */
    set_sleep_mode(SLEEP_MODE_IDLE);
    irq_on();
    session_init();
    for (;;) {
        cli();
        uint8_t wake = main_wake;
        if (!wake) {
            sleep_enable();
            sei();
            sleep_cpu();
            sleep_disable();
            continue;
        }
        main_wake = 0;
        irq_on();
        uint8_t frames = 0;
        if (wake & WAKE_RX)
            while (frame_receive(&frame)) {
                session_frame(&frame);
                frames = 1;
            }
        if (wake & WAKE_TICK) {
            stepgen_poll();
            device_poll();
        }
        if (wake & WAKE_LIMIT)
            limits_poll();
        if (wake & (WAKE_TICK | WAKE_INPUT))
            inputs_poll();
        if (frames || (wake & (WAKE_TICK | WAKE_IDLE)))
            outputs_poll();
        if (frames || (wake & (WAKE_TICK | WAKE_TX | WAKE_INPUT | WAKE_LIMIT)))
            session_poll();
    }
}
