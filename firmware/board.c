/* Arduino pin numbers to I/O registers (see board.h). */
#include <avr/io.h>

#include "board.h"
#include "irq.h"

volatile uint8_t *board_pin_reg(uint8_t pin)
{
    if (pin < 8)
        return &PIND;
    if (pin < 14)
        return &PINB;
    if (pin < BOARD_PINS)
        return &PINC;
    return 0;
}

uint8_t board_pin_mask(uint8_t pin)
{
    if (pin < 8)
        return (uint8_t)(1u << pin);
    if (pin < 14)
        return (uint8_t)(1u << (pin - 8));
    if (pin < BOARD_PINS)
        return (uint8_t)(1u << (pin - 14));
    return 0;
}

uint8_t board_pin_usable(uint8_t pin)
{
    return pin >= 2 && pin < BOARD_PINS;
}

void board_pin_write(uint8_t pin, uint8_t level)
{
    volatile uint8_t *reg = board_pin_reg(pin);
    uint8_t mask = board_pin_mask(pin);
    if (!reg)
        return;
    /* the step interrupt toggles direction pins on the same ports (a PINx write) */
    uint8_t sreg = irq_save();
    if (level)
        reg[2] |= mask;
    else
        reg[2] &= (uint8_t)~mask;
    reg[1] |= mask;
    irq_restore(sreg);
}

void board_pin_input(uint8_t pin, uint8_t pullup)
{
    volatile uint8_t *reg = board_pin_reg(pin);
    uint8_t mask = board_pin_mask(pin);
    if (!reg)
        return;
    uint8_t sreg = irq_save();
    reg[1] &= (uint8_t)~mask;
    if (pullup)
        reg[2] |= mask;
    else
        reg[2] &= (uint8_t)~mask;
    irq_restore(sreg);
}

uint8_t board_pin_port(uint8_t pin)
{
    return pin < 8 ? 2 : pin < 14 ? 0 : 1;
}
