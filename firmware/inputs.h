/* Inputs of the board (docs/serial-protocol.md section 18): watched digital pins
 * (reported when they change: pin-change interrupt) and analog pins A0-A7 (the A/D
 * converter, sampled every period_ms, reported when the value changed), each
 * reported again with the slow refresh.  In simavr the harness is the world outside
 * the board: SetInput turns its pots and presses its switches. */
#ifndef FW_INPUTS_H
#define FW_INPUTS_H

#include <stdint.h>

#define WATCHES 8  /* watched pins at a time; more are refused */

/* At boot: does a simulator's harness stand for the world outside (simavr)? */
void inputs_init(void);
extern uint8_t inputs_simulated;
/* A new session: nothing watched. */
void inputs_reset(void);
/* WatchInput and SetInput (type byte at m[0]). */
void inputs_watch(const uint8_t *m);
void inputs_world(const uint8_t *m);
/* A watched pin changed, at this tick (set by the pin-change interrupt). */
extern volatile uint32_t inputs_change_tick;
extern volatile uint8_t inputs_changed;
/* Main loop: read what changed (digital) or is due (analog). */
void inputs_poll(void);
/* The slow refresh: every watched input is reported again. */
void inputs_refresh(void);
/* The pin-change interrupts the watches and the limits need. */
void inputs_update_pcint(void);
/* Input reports: anything to send; put what fits (a new frame each call); the frame
 * with them went out. */
uint8_t inputs_due(void);
uint8_t inputs_put(uint8_t *p, uint8_t room);
void inputs_sent(void);

#endif
