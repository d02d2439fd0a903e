/* The device's queues as the protocol sees them: configuration, queue end position,
 * stop state, and the messages that act on them (docs/serial-protocol.md, sections
 * 5, 8 and 10).  The entries themselves and their execution are in stepgen.c. */
#ifndef FW_DEVICE_H
#define FW_DEVICE_H

#include <stdint.h>

#include "config.h"

struct counters {
    uint32_t frames_ok;
    uint32_t entries;
    /* u16 each, in DeviceStatus order */
    uint16_t frames_duplicate;
    uint16_t frames_out_of_order;
    uint16_t crc_errors;
    uint16_t framing_errors;
    uint16_t entries_lost;
    uint16_t entries_duplicated;
    uint16_t overflows;
    uint16_t underruns;
    uint16_t late_starts;
    uint16_t watchdog_trips;
    uint16_t rejected;
    uint16_t tx_dropped;
    uint16_t frames_held;
    uint16_t cuts;
    uint16_t cuts_refused;
    uint16_t halts;
    uint16_t discarded;
};
extern struct counters counters;

struct devq {
    uint8_t configured;
    uint8_t step_pin;
    uint8_t dir_pin;
    uint8_t halt_id;      /* the last Halt acted on or ForceStop taken */
    uint8_t halted;       /* a Halt stopped the queue: its ForceStop has not come */
    uint8_t refused;      /* a Truncate came too late */
    uint16_t underruns;
    int32_t end_pos;      /* position at the end of the queue */
};
extern struct devq devq[FW_MAX_STEPPERS];

/* the session's motion lock: after a watchdog trip or an emergency stop no entry or
 * start is taken until the next Hello */
extern uint8_t device_locked;

void device_init(void);
/* Act on one sequenced message (its type byte at msg[0], size already checked). */
void device_sequenced(const uint8_t *msg);
/* A refused cut to report in the next frame: its stepper (255: none). */
extern uint8_t device_report_stepper;
/* Halt (unsequenced) for the session `nonce_ok`; returns the stepper to report
 * (255: none). */
uint8_t device_halt(uint8_t stepper, uint8_t stop_id, uint8_t nonce_ok);
/* Stop every queue where it is (positions stay exact); `reset_stops`: a new session. */
void device_halt_all(uint8_t reset_stops);

/* Reports. */
struct progress {
    uint8_t flags;
    uint8_t index;
    uint8_t steps_left;
    int16_t pcnt;
};
void device_progress(uint8_t ch, struct progress *p);
int32_t device_position(uint8_t ch);
uint32_t device_pulses(uint8_t ch);

/* Main loop: starts whose first compare is past become Started reports. */
void device_poll(void);
/* A new session: no Started to send. */
void device_reset_reports(void);
/* Started reports: anything to send; put what fits (a new frame each call); the
 * frame with them went out. */
uint8_t device_started_due(void);
uint8_t device_started_put(uint8_t *p, uint8_t room);
void device_started_sent(void);

#endif
