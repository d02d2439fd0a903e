/* The protocol's session and link layer on the device: Hello/Ident, sequencing with
 * out-of-order slots and Naks, acknowledgements, unsequenced messages, reports, the
 * host-silence watchdog (docs/serial-protocol.md, sections 3, 4, 6, 7, 9, 11). */
#ifndef FW_SESSION_H
#define FW_SESSION_H

#include <stdint.h>

#include "frame.h"

void session_init(void);
/* A valid frame from the line. */
void session_frame(const struct frame_in *f);
/* Watchdog, due reports, and sending what is owed (as far as the line takes it). */
void session_poll(void);
/* Something is owed that the transmit ring had no room for. */
uint8_t session_busy(void);

#endif
