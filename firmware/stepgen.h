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
#include "uart.h"

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
    volatile uint8_t limit_block;  /* LB_*: a closed limit switch forbids that direction */
    volatile uint8_t limit_hit;    /* a limit stopped the queue; the main loop finishes it */
    uint8_t started;               /* a start to report (Started) once start_tick is past */
    uint32_t start_tick;           /* the tick of the first compare of that start */
};

/* limit_block bits: steps that count down (up) are forbidden */
#define LB_DOWN 0x01
#define LB_UP 0x02
/* the LB_* bit of an entry's direction (its flags) */
#define BLOCK_BIT(flags) ((uint8_t)(((flags) & QE_COUNT_UP) ? LB_UP : LB_DOWN))

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

/* Limit switches (limits.c).  With interrupts off: the directions a closed switch
 * forbids (LB_*; the compare interrupt then checks every entry that begins; the
 * slow flag sends it there), and a stop before the channels' next pulse - a pulse
 * already on the pin, or whose compare is too close to be taken back, is finished
 * and counted by the interrupts. */
static inline __attribute__((always_inline)) void stepgen_set_block(uint8_t ch, uint8_t block)
{
    struct stepq *q = &stepq[ch];
    q->limit_block = block;
    q->slow = q->detached | (q->pcnt_flags & PCNT_ON) | block;
}
/* (the channels of `mask`, a bit each, all at once; inline: the pin-change
 * interrupt calls nothing, so that it begins at once) */
#define HALT_LEAD 32  /* a compare this close to the counter read is not taken back */

static inline __attribute__((always_inline)) uint8_t stepgen_halt_decide(
    uint8_t ch, uint16_t ocr, uint16_t tcnt, uint8_t flag_set)
{
    struct stepq *q = &stepq[ch];
    uint8_t st = q->state;
    if (st & SQ_PENDING) {
        q->state = 0;  /* a timed start that waits: nothing on the pin yet */
        return 0;
    }
    if (!(st & SQ_RUNNING) || (st & SQ_STOPPING))
        return 0;
    if (!(st & SQ_FALLING)
            && (!(st & SQ_ARMED) || (!flag_set && (uint16_t)(ocr - tcnt) >= HALT_LEAD))) {
        q->state = 0;  /* no pulse on the pin and none before it is disconnected */
        return 1;
    }
    q->state = st | SQ_STOPPING;  /* a pulse on the pin, or about to be: finished */
    return 0;
}

static inline __attribute__((always_inline)) void stepgen_halt_isr(uint8_t mask)
{
    uint16_t tcnt = TCNT1;
    uint8_t tifr = TIFR1;
    uint8_t off = 0;
    if ((mask & 1) && stepgen_halt_decide(0, OCR1A, tcnt, tifr & _BV(OCF1A)))
        off |= _BV(COM1A1) | _BV(COM1A0);
    if ((mask & 2) && stepgen_halt_decide(1, OCR1B, tcnt, tifr & _BV(OCF1B)))
        off |= _BV(COM1B1) | _BV(COM1B0);
    if (off) {
        TCCR1A &= (uint8_t)~off;
        main_wake |= WAKE_IDLE;
    }
}
/* A start that has not begun yet is not reported (the queue was stopped before). */
void stepgen_forget_start(uint8_t ch);

#endif
