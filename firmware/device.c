/* The messages that act on the queues (see device.h). */
#include <avr/io.h>

#include "board.h"
#include "device.h"
#include "inputs.h"
#include "irq.h"
#include "limits.h"
#include "outputs.h"
#include "proto.h"
#include "stepgen.h"
#include "ticks.h"

struct counters counters;
struct devq devq[FW_MAX_STEPPERS];
uint8_t device_locked;

static const uint8_t step_pins[FW_MAX_STEPPERS] = {STEP_PIN_A, STEP_PIN_B};

void device_init(void)
{
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        devq[ch].configured = 0;
        devq[ch].dir_pin = PIN_NONE;
    }
}

/* the queue of `stepper` if it is configured; counts `rejected` otherwise */
static struct devq *queue(uint8_t stepper)
{
    if (stepper < FW_MAX_STEPPERS && devq[stepper].configured)
        return &devq[stepper];
    counters.rejected++;
    return 0;
}

/* halted or after a refused cut: this message for the queue is dropped */
static uint8_t discarding(struct devq *d)
{
    if (d->halted || d->refused) {
        counters.discarded++;
        return 1;
    }
    return 0;
}

static int32_t signed_steps(const struct qentry *e)
{
    return (e->flags & QE_COUNT_UP) ? (int32_t)e->steps : -(int32_t)e->steps;
}

/* Stop the queue where the pulses are; empty it at `index` (read = write); its end
 * is where the pulses stopped. */
static void stop_at(uint8_t ch, uint8_t index)
{
    stepgen_force_stop(ch);
    stepgen_forget_start(ch);
    struct stepq *q = &stepq[ch];
    uint8_t sreg = irq_save();
    q->rp = index;
    q->wp = index;
    irq_restore(sreg);
    struct stepq_snapshot s;
    stepgen_snapshot(ch, &s);
    devq[ch].end_pos = s.pulse_pos;
}

void device_halt_all(uint8_t reset_stops)
{
    outputs_cancel();  /* synchronized output changes not made yet go with the motion */
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        if (!devq[ch].configured)
            continue;
        stop_at(ch, stepq[ch].wp);
        if (reset_stops) {
            devq[ch].halt_id = 0;
            devq[ch].halted = 0;
            devq[ch].refused = 0;
        }
    }
}

static void config(const uint8_t *m)
{
    uint8_t ch = m[1];
    if (ch >= FW_MAX_STEPPERS || m[2] != step_pins[ch]) {
        counters.rejected++;  /* timer 1 has two channels, on pins 9 and 10 */
        return;
    }
    struct devq *d = &devq[ch];
    stepgen_force_stop(ch);
    stepgen_forget_start(ch);
    uint8_t index = m[4];
    uint8_t sreg = irq_save();
    stepq[ch].rp = index;
    stepq[ch].wp = index;
    irq_restore(sreg);
    d->configured = 1;
    d->step_pin = m[2];
    d->dir_pin = m[3];
    d->halt_id = d->halted = d->refused = 0;
    d->underruns = 0;
    d->end_pos = (int32_t)get_u32(m + 5);
    stepgen_set_dir_pin(ch, d->dir_pin);
    stepgen_set_counts(ch, 0, d->end_pos);
}

static void entry(const uint8_t *m)
{
    uint8_t ch = m[0] & 0x07;
    struct devq *d = queue(ch);
    if (!d)
        return;
    if (device_locked) {
        counters.rejected++;
        return;
    }
    if (discarding(d))
        return;
    uint8_t flags = m[1];
    struct stepq *q = &stepq[ch];
    uint8_t wp = q->wp;
    uint8_t gap = (uint8_t)(flags - wp) & E_INDEX_MASK;
    if (gap >= 8) {
        counters.entries_duplicated++;
        return;
    }
    if (gap)
        counters.entries_lost += gap;
    if ((uint8_t)(wp - q->rp) >= QUEUE_LEN) {
        counters.overflows++;
        return;
    }
    struct qentry *e = &q->entry[wp & QUEUE_MASK];
    e->steps = m[2];
    e->flags = flags & (E_TOGGLE_DIR | E_DIR_LEVEL | E_COUNT_UP);
    e->ticks = get_u16(m + 3);
    stepgen_commit_entry(ch);
    d->end_pos += signed_steps(e);
    counters.entries++;
    if ((flags & E_CONT) && !(q->state & (SQ_RUNNING | SQ_PENDING))) {
        /* the host meant this to follow a running queue, which already ran dry */
        counters.underruns++;
        d->underruns++;
        stepgen_start_now(ch);
    }
}

static void start(const uint8_t *m)
{
    uint8_t mask = m[1];
    uint32_t at = get_u32(m + 2);
    for (uint8_t ch = 0; ch < 8; ch++) {
        if (!(mask & (1u << ch)))
            continue;
        struct devq *d = queue(ch);
        if (!d)
            continue;
        if (device_locked) {
            counters.rejected++;
            continue;
        }
        if (discarding(d))
            continue;
        if (stepgen_start_at(ch, at))
            counters.late_starts++;
    }
}

static void force_stop(const uint8_t *m)
{
    struct devq *d = queue(m[1]);
    if (!d)
        return;
    stop_at(m[1], m[2]);
    d->halted = d->refused = 0;
    d->halt_id = m[3];
}

uint8_t device_halt(uint8_t stepper, uint8_t stop_id, uint8_t nonce_ok)
{
    if (!nonce_ok || stepper >= FW_MAX_STEPPERS || !devq[stepper].configured) {
        counters.rejected++;
        return 255;
    }
    struct devq *d = &devq[stepper];
    if (stop_id == d->halt_id)
        return 255;  /* a copy of a Halt already acted on (or whose ForceStop came) */
    d->halt_id = stop_id;
    d->halted = 1;
    d->refused = 0;
    counters.halts++;
    stop_at(stepper, stepq[stepper].wp);
    return stepper;
}

/* Truncate: a cut, if none of the entries from `index` on has begun; returns the
 * stepper to report (a refused cut) or 255. */
static uint8_t truncate(const uint8_t *m)
{
    uint8_t ch = m[1];
    struct devq *d = queue(ch);
    if (!d)
        return 255;
    if (d->halted) {
        counters.discarded++;
        return 255;
    }
    struct stepq *q = &stepq[ch];
    uint8_t index = m[2];
    uint8_t sreg = irq_save();  /* the read index must not move while the cut is decided */
    uint8_t rp = q->rp, wp = q->wp;
    uint8_t fill = wp - rp, dist = index - rp;
    if (dist > fill || (dist == 0 && fill && (q->state & SQ_RUNNING))) {
        irq_restore(sreg);
        d->refused = 1;
        counters.cuts_refused++;
        return ch;
    }
    if (dist < fill)
        q->wp = index;  /* entries from index on are gone before the interrupt sees them */
    irq_restore(sreg);
    d->refused = 0;
    if (dist == fill)
        return 255;  /* a cut at the write index drops nothing */
    counters.cuts++;
    for (uint8_t i = index; i != wp; i++)
        d->end_pos -= signed_steps(&q->entry[i & QUEUE_MASK]);
    return 255;
}

static void set_end_pos(const uint8_t *m)
{
    uint8_t ch = m[1];
    struct devq *d = queue(ch);
    if (!d || discarding(d))
        return;
    int32_t delta = (int32_t)get_u32(m + 2) - d->end_pos;
    if (delta) {
        d->end_pos += delta;
        struct stepq_snapshot s;
        stepgen_snapshot(ch, &s);
        stepgen_set_counts(ch, s.pulses, s.pulse_pos + delta);
    }
}

static void pin(const uint8_t *m)
{
    if (!board_pin_usable(m[1])) {
        counters.rejected++;
        return;
    }
    board_pin_write(m[1], m[2]);
}

static void dir_pin(const uint8_t *m)
{
    struct devq *d = queue(m[1]);
    if (!d)
        return;
    d->dir_pin = m[2];
    stepgen_set_dir_pin(m[1], m[2]);
}

uint8_t device_report_stepper = 255;

void device_sequenced(const uint8_t *m)
{
    uint8_t type = m[0];
    if ((type & 0xF8) == M_ENTRY) {
        entry(m);
        return;
    }
    switch (type) {
    case M_CONFIG:
        config(m);
        break;
    case M_DIR_PIN:
        dir_pin(m);
        break;
    case M_TRUNCATE:
        device_report_stepper = truncate(m);
        break;
    case M_START:
        start(m);
        break;
    case M_FORCE_STOP:
        force_stop(m);
        break;
    case M_SET_END_POS:
        set_end_pos(m);
        break;
    case M_PIN:
        pin(m);
        break;
    case M_DETACH:
        if (queue(m[1]))
            stepgen_set_detached(m[1], m[2]);
        break;
    case M_PCNT_ATTACH:
        if (queue(m[1]))
            stepgen_set_pcnt(m[1], PCNT_ON | (m[6] ? PCNT_DIR_HIGH_UP : 0),
                             (int16_t)get_u16(m + 2), (int16_t)get_u16(m + 4),
                             (int16_t)get_u16(m + 7));
        break;
    case M_PCNT_CLEAR:
        if (queue(m[1]))
            stepgen_pcnt_clear(m[1]);
        break;
    case M_OUTPUT_PWM:
        outputs_pwm(m);
        break;
    case M_OUTPUT_SET:
        outputs_set(m);
        break;
    case M_OUTPUT_CANCEL:
        outputs_cancel();
        break;
    case M_OUTPUT_AT:
        outputs_at(m);
        break;
    case M_OUTPUT_NEXT:
        outputs_next(m);
        break;
    case M_WATCH_INPUT:
        inputs_watch(m);
        break;
    case M_LIMIT:
        limits_message(m);
        break;
    case M_SET_INPUT:
        inputs_world(m);
        break;
    default:
        counters.rejected++;  /* a known message that does not belong in the sequence */
        break;
    }
}

void device_progress(uint8_t ch, struct progress *p)
{
    struct stepq_snapshot s;
    stepgen_snapshot(ch, &s);
    struct stepq *q = &stepq[ch];
    struct devq *d = &devq[ch];
    uint8_t flags = 0;
    p->steps_left = 0;
    if (s.rp != q->wp) {
        flags |= P_HAS_ENTRY;
        p->steps_left = s.steps;
    }
    if (s.state & SQ_RUNNING)
        flags |= P_RUNNING;
    if (s.state & SQ_PENDING)
        flags |= P_START_PENDING;
    if (q->detached)
        flags |= P_DETACHED;
    if (d->halted)
        flags |= P_HALTED;
    if (d->refused)
        flags |= P_CUT_REFUSED;
    p->pcnt = 0;
    if (q->pcnt_flags & PCNT_ON) {
        flags |= P_HAS_PCNT;
        p->pcnt = s.pcnt;
    }
    p->flags = flags;
    p->index = s.rp;
}

int32_t device_position(uint8_t ch)
{
    struct stepq *q = &stepq[ch];
    for (;;) {
        uint8_t sreg = irq_save();
        uint8_t rp = q->rp, wp = q->wp;
        struct qentry first = q->entry[rp & QUEUE_MASK];
        irq_restore(sreg);
        int32_t pos = devq[ch].end_pos;
        if (rp == wp)
            return pos;
        /* back from the queue's end to the end of the entry at rp */
        for (uint8_t i = rp + 1; i != wp; i++)
            pos -= signed_steps(&q->entry[i & QUEUE_MASK]);
        if (q->rp != rp)
            continue;  /* the interrupt moved on meanwhile: again */
        if (first.steps == 0)
            return pos;
        return (first.flags & QE_COUNT_UP) ? pos - first.steps : pos + first.steps;
    }
}

/* Started: a start is reported once its first compare is past (a queue stopped
 * before it began has nothing to report). */
static uint8_t started_due;  /* bit per queue */
static uint8_t started_put;
static uint32_t started_tick[FW_MAX_STEPPERS];

void device_poll(void)
{
    uint32_t now = ticks_now();
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        struct stepq *q = &stepq[ch];
        if (q->started && (int32_t)(now - q->start_tick) >= 0) {
            q->started = 0;
            started_tick[ch] = q->start_tick;
            started_due |= 1u << ch;
        }
    }
}

void device_reset_reports(void)
{
    started_due = 0;
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++)
        stepq[ch].started = 0;
}

uint8_t device_started_due(void)
{
    return started_due;
}

uint8_t device_started_put(uint8_t *p, uint8_t room)
{
    uint8_t n = 0;
    started_put = 0;
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        if (!(started_due & (1u << ch)) || n + SIZE_STARTED > room)
            continue;
        p[n] = M_STARTED;
        p[n + 1] = ch;
        put_u32(p + n + 2, started_tick[ch]);
        n += SIZE_STARTED;
        started_put |= 1u << ch;
    }
    return n;
}

void device_started_sent(void)
{
    started_due &= (uint8_t)~started_put;
    started_put = 0;
}

uint32_t device_pulses(uint8_t ch)
{
    struct stepq_snapshot s;
    stepgen_snapshot(ch, &s);
    return s.pulses;
}
