/* Step generation: one command queue per timer-1 channel (A: pin 9, B: pin 10),
 * executed by the channel's compare interrupt exactly as FastAccelStepper's AVR
 * driver does it.
 *
 * A queue entry means `steps` pulses `ticks` apart, then one more `ticks` of wait;
 * `steps == 0` is a pause.  The compare unit raises the step pin at the compare tick
 * (hardware, exact); the interrupt then takes the pin low again, counts the step,
 * and programs the next compare at previous compare + ticks.  The main loop writes
 * entries at `wp`; the interrupt reads at `rp`.
 *
 * Without the timers' force-output-compare (FOC1x is not modelled by simavr 1.6 and
 * is not needed here) the pin is taken low by a second compare: the interrupt puts
 * the channel in "clear on compare" mode with the compare a few ticks ahead; the
 * interrupt of that compare programs the next step.  Pauses and idle channels are
 * disconnected from the pin (COM = 00), so the output flip-flop only ever changes at
 * a compare match.
 */
#ifndef FW_STEPGEN_H
#define FW_STEPGEN_H

#include <stdint.h>

#include "config.h"

#define QE_TOGGLE_DIR_BIT 4
#define QE_TOGGLE_DIR (1 << QE_TOGGLE_DIR_BIT)  /* toggle the direction pin at the start */
#define QE_DIR_LEVEL 0x20   /* the direction pin level during the entry */
#define QE_COUNT_UP_BIT 6
#define QE_COUNT_UP (1 << QE_COUNT_UP_BIT)  /* the entry's steps count the position up */

struct qentry {
    uint8_t steps;   /* pulses still to make (counted down by the interrupt) */
    uint8_t flags;   /* QE_* */
    uint16_t ticks;  /* pulse period; after the last pulse one more period */
};

/* state bits */
#define SQ_RUNNING_BIT 0
#define SQ_RUNNING (1 << SQ_RUNNING_BIT)    /* the compare interrupt works on the queue */
#define SQ_PENDING 0x02   /* a timed start waits for its tick */
#define SQ_NO_MORE_BIT 2
#define SQ_NO_MORE (1 << SQ_NO_MORE_BIT)    /* the queue ran dry: the last period runs */
#define SQ_ARMED_BIT 3
#define SQ_ARMED (1 << SQ_ARMED_BIT)        /* the coming step compare makes a pulse */
#define SQ_FALLING_BIT 4
#define SQ_FALLING (1 << SQ_FALLING_BIT)    /* the coming compare ends the pulse */
#define SQ_STOPPING_BIT 5
#define SQ_STOPPING (1 << SQ_STOPPING_BIT)  /* stop once the pulse in flight is done */
#define SQ_FLUSH 0x40     /* the interrupt runs once to consume a stale flag */
#define SQ_TOGGLE_BIT 7
#define SQ_TOGGLE (1 << SQ_TOGGLE_BIT)      /* toggle the direction at the falling edge */

/* pulse counter flags */
#define PCNT_ON 0x01
#define PCNT_DIR_HIGH_UP 0x02

struct stepq {
    struct qentry entry[QUEUE_LEN];
    volatile uint8_t rp;      /* read index (interrupt) */
    volatile uint8_t wp;      /* write index (main loop) */
    volatile uint8_t state;   /* SQ_* */
    volatile uint8_t detached;        /* pulses are counted but not put on the pin */
    volatile uint8_t *volatile dir_reg;  /* PINx of the direction pin (or a dummy) */
    volatile uint8_t dir_mask;
    volatile uint16_t pulses_up;    /* pulses made with count_up, and without; the */
    volatile uint16_t pulses_down;  /* main loop folds them into pulses and pulse_pos */
    uint32_t pulses;             /* pulses made since the queue was configured */
    int32_t pulse_pos;           /* position counted from the pulses made */
    volatile uint16_t start_wraps;  /* compare matches before a pending start */
    uint16_t next_compare;       /* the step compare after the falling edge ... */
    uint8_t next_com;            /* ... and the channel's output mode for it */
    volatile uint8_t slow;       /* detached or a pulse counter: the interrupt's C path */
    volatile uint8_t pcnt_flags;
    volatile int16_t pcnt;
    int16_t pcnt_low;
    int16_t pcnt_high;
};

extern struct stepq stepq[FW_MAX_STEPPERS];

void stepgen_init(void);
/* Start the queue now: first compare 10 ticks from now (FastAccelStepper's
 * startQueue).  Nothing happens if it runs or is empty. */
void stepgen_start_now(uint8_t ch);
/* Start the queue so that its first compare is at tick `at + 10` (a start for a tick
 * that has passed starts now).  Returns 1 if `at` had passed. */
uint8_t stepgen_start_at(uint8_t ch, uint32_t at);
/* Stop at once: the pulse in flight is completed and counted, nothing more. */
void stepgen_force_stop(uint8_t ch);
/* A consistent view of the queue for reports. */
struct stepq_snapshot {
    uint8_t state;
    uint8_t rp;
    uint8_t steps;  /* steps left of the entry at rp (if rp != wp) */
    uint32_t pulses;
    int32_t pulse_pos;
    int16_t pcnt;
};
void stepgen_snapshot(uint8_t ch, struct stepq_snapshot *s);
/* The direction pin toggled by entries (PIN_NONE or an external pin: none). */
void stepgen_set_dir_pin(uint8_t ch, uint8_t pin);
/* Pulses counted but not put on the pin (the step pin given to the application). */
void stepgen_set_detached(uint8_t ch, uint8_t detached);
/* The pulse counter: PCNT_* flags (0: off), limits, value; and clearing it. */
void stepgen_set_pcnt(uint8_t ch, uint8_t flags, int16_t low, int16_t high, int16_t value);
void stepgen_pcnt_clear(uint8_t ch);
/* Fold the interrupt's pulse counts into pulses/pulse_pos (call often: the 16-bit
 * counts must not wrap between calls). */
void stepgen_poll(void);
void stepgen_set_counts(uint8_t ch, uint32_t pulses, int32_t pulse_pos);
/* Publish the entry written at entry[wp & QUEUE_MASK]. */
void stepgen_commit_entry(uint8_t ch);

#endif
