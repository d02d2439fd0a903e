/* Interrupt-off sections.  irq_restore() gives pending interrupts a chance before the
 * caller can turn them off again: two instructions after the interrupt flag is set.
 * On the chip one would do; simavr 1.6 takes a pending interrupt only after the
 * second instruction following, so a loop of short sections would starve them. */
#ifndef FW_IRQ_H
#define FW_IRQ_H

#include <avr/io.h>
#include <stdint.h>

static inline __attribute__((always_inline)) uint8_t irq_save(void)
{
    uint8_t sreg = SREG;
    __asm__ __volatile__("cli" ::: "memory");
    return sreg;
}

static inline __attribute__((always_inline)) void irq_restore(uint8_t sreg)
{
    SREG = sreg;
    __asm__ __volatile__("nop\n\tnop" ::: "memory");
}

static inline __attribute__((always_inline)) void irq_on(void)
{
    __asm__ __volatile__("sei\n\tnop\n\tnop" ::: "memory");
}

#endif
