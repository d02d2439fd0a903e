/* The device clock: timer 1 at the CPU clock (16 MHz), extended to 32 bits by its
 * overflow interrupt.  Timer 1 also times the step pulses (stepgen.c). */
#ifndef FW_TICKS_H
#define FW_TICKS_H

#include <avr/io.h>
#include <stdint.h>

#include "irq.h"

extern volatile uint16_t ticks_high;

void ticks_init(void);

/* The current tick (wraps after 268 s); callable with interrupts on or off.  Inline,
 * so that an interrupt using it needs no call. */
static inline __attribute__((always_inline)) uint32_t ticks_now(void)
{
    uint8_t sreg = irq_save();
    uint16_t high = ticks_high;
    uint16_t low = TCNT1;
    /* an overflow whose interrupt has not run yet belongs to a low value read after it */
    if ((TIFR1 & _BV(TOV1)) && low < 0x8000u)
        high++;
    irq_restore(sreg);
    return ((uint32_t)high << 16) | low;
}

/* The tick at which TCNT1 read `low` (interrupts off since the read, less than a
 * counter wrap ago). */
static inline __attribute__((always_inline)) uint32_t ticks_at(uint16_t low)
{
    uint16_t high = ticks_high;
    if ((TIFR1 & _BV(TOV1)) && low < 0x8000u)
        high++;
    return ((uint32_t)high << 16) | low;
}

#endif
