/* 32-bit tick counter on timer 1 (see ticks.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "ticks.h"

volatile uint16_t ticks_high;

ISR(TIMER1_OVF_vect)
{
    ticks_high++;
}

void ticks_init(void)
{
    TCCR1A = 0;              /* normal mode, outputs disconnected */
    TCCR1B = _BV(CS10);      /* prescaler 1: one tick per CPU cycle */
    TCCR1C = 0;
    TIFR1 = _BV(TOV1) | _BV(OCF1A) | _BV(OCF1B);
    TIMSK1 = _BV(TOIE1);
}
