/* Limit switches (docs/serial-protocol.md section 18): the device stops a queue that
 * steps towards a closed switch - when the switch closes (the pin-change interrupt)
 * and when an entry towards a switch already closed begins (the compare interrupt,
 * stepgen.c) - before a further pulse, stops the queues of the limit's stop mask with
 * it, leaves them halted and reports LimitHit. */
#ifndef FW_LIMITS_H
#define FW_LIMITS_H

#include <stdint.h>

/* A new session: no limits. */
void limits_reset(void);
/* The Limit message (type byte at m[0]). */
void limits_message(const uint8_t *m);
/* Interrupts off: queue `ch` was stopped before a pulse towards its limit `up` (by
 * the caller); note it for the main loop and stop the queues of the stop mask. */
void limits_hit(uint8_t ch, uint8_t up);
/* (The pin-change interrupt is here: it reads the switches again and stops a queue
 * whose next pulses go towards a closed one.) */
/* Main loop: finish the stops the interrupts made (queue emptied and halted). */
void limits_poll(void);
/* The pin-change mask bits the limits need, per port (B, C, D: PCMSK0..2). */
void limits_pcint_mask(uint8_t mask[3]);
/* LimitHit reports: anything to send; put what fits (a new frame each call); the
 * frame with them went out. */
uint8_t limits_due(void);
uint8_t limits_put(uint8_t *p, uint8_t room);
void limits_sent(void);

#endif
