/* Limit switches (see limits.h). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "device.h"
#include "inputs.h"
#include "irq.h"
#include "limits.h"
#include "proto.h"
#include "stepgen.h"
#include "ticks.h"
#include "uart.h"

struct limit {
    volatile uint8_t *reg;  /* PINx of the switch (0: no limit) */
    uint8_t mask;           /* its bit */
    uint8_t level;          /* PINx & mask of a closed switch (0 or mask) */
    uint8_t pin;
    uint8_t stop_mask;      /* queues stopped with this one */
};
static struct limit limits[FW_MAX_STEPPERS][2];  /* [queue][up] */

/* A stop to finish (stepq.limit_hit) and to report (HIT_DUE). */
#define HIT_DUE 1
static struct {
    uint8_t state;
    uint8_t pin;
    uint8_t index;
    int32_t position;
    uint32_t tick;
} hits[FW_MAX_STEPPERS];
static uint8_t put_mask;  /* LimitHit in the frame being built, bit per queue */

void limits_reset(void)
{
    uint8_t sreg = irq_save();
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        limits[ch][0].reg = 0;
        limits[ch][1].reg = 0;
        stepgen_set_block(ch, 0);
        stepq[ch].limit_hit = 0;
        hits[ch].state = 0;
    }
    irq_restore(sreg);
}

/* The queues that move (bit per queue) and are not stopped by a limit already. */
static inline __attribute__((always_inline)) uint8_t moving(void)
{
    return (uint8_t)(((stepq[0].state & SQ_RUNNING) && !stepq[0].limit_hit ? 1 : 0)
                     | ((stepq[1].state & SQ_RUNNING) && !stepq[1].limit_hit ? 2 : 0));
}

/* Queue `ch` stopped at its limit `up`, and the queues `others` with it (all halted
 * by the caller): for the main loop to finish and report. */
static inline __attribute__((always_inline)) void note(uint8_t ch, uint8_t up,
                                                       uint8_t others, uint32_t tick)
{
    uint8_t pin = limits[ch][up].pin;
    others |= (uint8_t)(1u << ch);
    for (uint8_t o = 0; o < FW_MAX_STEPPERS; o++) {
        if (!(others & (1u << o)) || stepq[o].limit_hit)
            continue;
        hits[o].pin = pin;
        hits[o].tick = tick;
        stepq[o].limit_hit = 1;
    }
    main_wake |= WAKE_LIMIT;
}

void limits_hit(uint8_t ch, uint8_t up)
{
    uint8_t others = limits[ch][up].stop_mask & moving() & (uint8_t)~(1u << ch);
    if (others)
        stepgen_halt_isr(others);
    note(ch, up, others, ticks_now());
}

/* Queue `ch`'s switches now: the LB_* bits of the closed ones. */
static inline __attribute__((always_inline)) uint8_t closed(uint8_t ch)
{
    const struct limit *l = limits[ch];
    uint8_t block = 0;
    if (l[0].reg && (*l[0].reg & l[0].mask) == l[0].level)
        block = LB_DOWN;
    if (l[1].reg && (*l[1].reg & l[1].mask) == l[1].level)
        block |= LB_UP;
    return block;
}

/* 1 + up if queue `ch` moves and its next pulses go towards a closed switch of
 * `block`, else 0. */
static inline __attribute__((always_inline)) uint8_t towards(uint8_t ch, uint8_t block)
{
    const struct stepq *q = &stepq[ch];
    if (!block || (q->state & (SQ_RUNNING | SQ_STOPPING)) != SQ_RUNNING || q->limit_hit)
        return 0;
    /* the entry at the read index, or the first after it with steps */
    for (uint8_t rp = q->rp, wp = q->wp; rp != wp; rp++) {
        const struct qentry *e = &q->entry[rp & QUEUE_MASK];
        if (e->steps) {
            uint8_t dir = BLOCK_BIT(e->flags);
            return (dir & block) ? (uint8_t)(1 + (dir == LB_UP)) : 0;
        }
    }
    return 0;
}

/* After the stop: the directions the switches forbid, the notes for the main loop,
 * the inputs' time stamp (a function of its own, so that the interrupt saves only
 * the registers of its first part before it acts). */
static void after_pin_change(uint16_t tcnt, uint8_t block0, uint8_t block1, uint8_t hits_now,
                             uint8_t others0, uint8_t others1)
{
    if (block0 != stepq[0].limit_block)
        stepgen_set_block(0, block0);
    if (block1 != stepq[1].limit_block)
        stepgen_set_block(1, block1);
    uint32_t tick = ticks_at(tcnt);
    if (hits_now & 0x03)
        note(0, (hits_now & 0x03) - 1, others0, tick);
    if (hits_now & 0x0C)
        note(1, (hits_now >> 2) - 1, others1, tick);
    inputs_change_tick = tick;
    inputs_changed = 1;
    main_wake |= WAKE_INPUT;
}

/* The switches are read again.  What stops is decided first and taken off the pins
 * at once (both channels in one write); the bookkeeping follows. */
static inline __attribute__((always_inline)) void pin_change(uint16_t tcnt)
{
    uint8_t block0 = closed(0);
    uint8_t block1 = closed(1);
    uint8_t hit0 = towards(0, block0);
    uint8_t hit1 = towards(1, block1);
    uint8_t others0 = 0, others1 = 0;
    if (hit0 || hit1) {
        uint8_t move = moving();
        others0 = hit0 ? limits[0][hit0 - 1].stop_mask & move & ~1u : 0;
        others1 = hit1 ? limits[1][hit1 - 1].stop_mask & move & ~2u : 0;
        stepgen_halt_isr((hit0 ? 1 : 0) | (hit1 ? 2 : 0) | others0 | others1);
    }
    after_pin_change(tcnt, block0, block1, (uint8_t)(hit0 | (hit1 << 2)), others0, others1);
}

/* Any pin change of a watched input or a limit switch (the three ports share it):
 * the limits first. */
ISR(PCINT0_vect)
{
    pin_change(TCNT1);
}
ISR(PCINT1_vect, ISR_ALIASOF(PCINT0_vect));
ISR(PCINT2_vect, ISR_ALIASOF(PCINT0_vect));

void limits_message(const uint8_t *m)
{
    uint8_t ch = m[1], pin = m[2], flags = m[4];
    if (ch >= FW_MAX_STEPPERS || !devq[ch].configured
            || (!(flags & L_CLEAR) && !board_pin_usable(pin))) {
        counters.rejected++;
        return;
    }
    struct limit *l = &limits[ch][flags & L_UP ? 1 : 0];
    uint8_t mask = board_pin_mask(pin);
    uint8_t sreg = irq_save();
    if (flags & L_CLEAR) {
        l->reg = 0;
    } else {
        l->reg = board_pin_reg(pin);
        l->mask = mask;
        l->level = m[3] ? mask : 0;
        l->pin = pin;
        l->stop_mask = m[5];
    }
    pin_change(TCNT1);  /* the directions it forbids from now on */
    irq_restore(sreg);
    inputs_update_pcint();
}

void limits_pcint_mask(uint8_t mask[3])
{
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++)
        for (uint8_t up = 0; up < 2; up++)
            if (limits[ch][up].reg)
                mask[board_pin_port(limits[ch][up].pin)] |= limits[ch][up].mask;
}

void limits_poll(void)
{
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        struct stepq *q = &stepq[ch];
        if (!q->limit_hit)
            continue;
        while (q->state)
            ;  /* a pulse on the pin: the interrupts finish and count it */
        uint8_t sreg = irq_save();
        q->rp = q->wp;
        q->limit_hit = 0;
        irq_restore(sreg);
        stepgen_forget_start(ch);
        struct stepq_snapshot s;
        stepgen_snapshot(ch, &s);
        struct devq *d = &devq[ch];
        d->end_pos = s.pulse_pos;
        d->halted = 1;  /* until the host's ForceStop (or Config), as after a Halt */
        d->refused = 0;
        hits[ch].index = q->wp;
        hits[ch].position = s.pulse_pos;
        hits[ch].state = HIT_DUE;
        main_wake |= WAKE_IDLE;  /* synchronized outputs wait for idle queues */
    }
}

uint8_t limits_due(void)
{
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++)
        if (hits[ch].state == HIT_DUE)
            return 1;
    return 0;
}

uint8_t limits_put(uint8_t *p, uint8_t room)
{
    uint8_t n = 0;
    put_mask = 0;
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        if (hits[ch].state != HIT_DUE || n + SIZE_LIMIT_HIT > room)
            continue;
        uint8_t *q = p + n;
        q[0] = M_LIMIT_HIT;
        q[1] = ch;
        q[2] = hits[ch].pin;
        q[3] = hits[ch].index;
        put_u32(put_u32(q + 4, (uint32_t)hits[ch].position), hits[ch].tick);
        n += SIZE_LIMIT_HIT;
        put_mask |= 1u << ch;
    }
    return n;
}

void limits_sent(void)
{
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++)
        if (put_mask & (1u << ch))
            hits[ch].state = 0;
    put_mask = 0;
}
