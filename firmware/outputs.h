/* User outputs (docs/serial-protocol.md, user outputs): four digital and four PWM
 * outputs, changed at once or after the motion commanded before them.
 *
 * PWM on the Uno: timer 2 (pins 3 = OC2B and 11 = OC2A; fast PWM, TOP 255, one
 * prescaler for both) and timer 0 (pins 5 = OC0B and 6 = OC0A; fast PWM, TOP 255,
 * prescaler 64 fixed, because timer 0's overflow is also the main loop's 1 ms tick).
 * Timer 1 makes the steps. */
#ifndef FW_OUTPUTS_H
#define FW_OUTPUTS_H

#include <stdint.h>

void outputs_init(void);
/* OutputPwm: number u8, pin u8, clock_div u32, counts u32, count u32 (msg[0]: type) */
void outputs_pwm(const uint8_t *msg);
/* OutputSet: flags u8, number u8, pin u8, value u32 */
void outputs_set(const uint8_t *msg);
/* OutputCancel: drop the synchronized changes not made yet */
void outputs_cancel(void);
/* OutputAt: flags u8, number u8, pin u8, value u32, at u32 - a change at device tick
 * `at` (T_CANCEL: drop those not made yet); at most TIMED_SLOTS wait.  Timer 2's
 * interrupts make its outputs' changes; outputs_poll the others. */
void outputs_at(const uint8_t *msg);
/* OutputNext: value u16, after u16 - the next change of the output of the session's
 * last OutputAt / OutputNext, `after` ticks after it (none yet: rejected) */
void outputs_next(const uint8_t *msg);
/* A new session: no timed change yet for an OutputNext to count from. */
void outputs_session(void);
/* PwmGrid reports (after OutputPwm): anything to send; put what fits; sent. */
uint8_t outputs_grid_due(void);
uint8_t outputs_grid_put(uint8_t *p, uint8_t room);
void outputs_grid_sent(void);
/* Make the timed changes of the main loop that are due, and the synchronized changes
 * that wait if every queue is idle. */
void outputs_poll(void);

#endif
