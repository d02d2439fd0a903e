/* Arduino pin numbers on the ATmega328P (Uno/Nano): 0-7 = PD0-7, 8-13 = PB0-5,
 * 14-19 = PC0-5 (A0-A5).  Pins 0 and 1 carry the UART and are never driven. */
#ifndef FW_BOARD_H
#define FW_BOARD_H

#include <stdint.h>

#define PIN_NONE 255
#define PIN_EXTERNAL 0x80  /* bit 7: a pin the host handles itself */
#define BOARD_PINS 20

/* The port of a pin: its PINx register (DDRx and PORTx follow at +1 and +2), or 0. */
volatile uint8_t *board_pin_reg(uint8_t pin);
uint8_t board_pin_mask(uint8_t pin);
/* May the host drive this pin (an existing pin that is not the UART's)? */
uint8_t board_pin_usable(uint8_t pin);
/* Make the pin an output at `level` (interrupt-safe read-modify-write). */
void board_pin_write(uint8_t pin, uint8_t level);
/* Make the pin an input, with the pull-up resistor or without. */
void board_pin_input(uint8_t pin, uint8_t pullup);
/* The port of a usable pin: 0 = B, 1 = C, 2 = D - the index of its pin-change mask
 * register (PCMSK0..2) and interrupt (PCINT0..2); its bit there is board_pin_mask(). */
uint8_t board_pin_port(uint8_t pin);

#endif
