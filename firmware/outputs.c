/* User outputs (see outputs.h). */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>

#include "board.h"
#include "device.h"
#include "irq.h"
#include "outputs.h"
#include "proto.h"
#include "stepgen.h"
#include "ticks.h"

#define O_ANALOG 0x01
#define O_SYNCHRONIZED 0x02
#define PWM_COUNTS 256  /* TOP 255 on both 8-bit timers */

/* the PWM pins: their timer's compare register and output mode bits */
enum { PWM_OC2B, PWM_OC2A, PWM_OC0B, PWM_OC0A, PWM_UNITS };
/* (tables in flash: the RAM is for the queues) */
static const uint8_t pwm_pin[PWM_UNITS] PROGMEM = {3, 11, 5, 6};
static uint8_t pwm_on;  /* bit per unit: configured by OutputPwm */

#define SYNC_CHANGES 8
static struct {
    uint8_t flags;
    uint8_t pin;
    uint16_t value;
} waiting[SYNC_CHANGES];
static uint8_t waiting_count;

/* timed changes (OutputAt), a ring in the order received (the host sends them in tick
 * order).  `unit`: the PWM unit of an analog change, or UNIT_DIGITAL.  Timer 2's changes
 * are made by its interrupts (on while one waits), the others by the main loop. */
#define T_CANCEL 0x80
#define TIMED_SLOTS 8
#define UNIT_DIGITAL 0xFF
static struct {
    uint32_t at;
    uint8_t value;  /* analog: the compare value (count - 1), or VALUE_OFF; digital: 0/1 */
    uint8_t unit;
    uint8_t pin;
} timed[TIMED_SLOTS];
#define VALUE_OFF 0xFF  /* (an analog count of 0: the pin disconnected and low) */
static volatile uint8_t timed_first, timed_count;
/* The PWM periods on the device clock (timer 1, the same 16 MHz): a tick at which each
 * timer was at BOTTOM and log2 of its period in ticks ([0]: timer 0, [1]: timer 2) -
 * both count from 0 when their clock starts.  Reading TCNT0/TCNT2 would do on the
 * chip; the clock keeps simavr's looser 8-bit timers out of it. */
static uint32_t period_origin[2];
static uint8_t period_log2[2] = {14, 14};
/* per timer-2 unit: the compare value written last, the one before it, and the
 * period it was written in - a value written in the running period takes effect at
 * its end (a change to 0 waits for the match in effect) */
static uint8_t ocr_last[2], ocr_before[2];
static uint16_t ocr_period[2];

void outputs_init(void)
{
    /* timer 0: fast PWM, TOP 255, prescaler 64 - its overflow every 1.024 ms is the
     * main loop's tick; its outputs stay disconnected until used */
    TCCR0A = _BV(WGM01) | _BV(WGM00);
    TCCR0B = _BV(CS01) | _BV(CS00);
    period_origin[0] = ticks_now();
    TIMSK0 = _BV(TOIE0);
}

/* PwmGrid reports: bit per PWM unit whose period grid is to be sent (after an
 * OutputPwm), and those put in the frame being sent */
static uint8_t grid_due, grid_put;

uint8_t outputs_grid_due(void)
{
    return grid_due;
}

uint8_t outputs_grid_put(uint8_t *p, uint8_t room)
{
    uint8_t n = 0;
    grid_put = 0;
    for (uint8_t u = 0; u < PWM_UNITS; u++) {
        if (!(grid_due & (1u << u)) || n + SIZE_PWM_GRID > room)
            continue;
        uint8_t t = u <= PWM_OC2A;  /* period_origin / period_log2: [1] timer 2, [0] timer 0 */
        uint8_t sreg = irq_save();
        uint32_t origin = period_origin[t];
        irq_restore(sreg);
        p[n] = M_PWM_GRID;
        p[n + 1] = pgm_read_byte(&pwm_pin[u]);
        put_u32(p + n + 2, origin);
        put_u32(p + n + 6, 1UL << period_log2[t]);
        n += SIZE_PWM_GRID;
        grid_put |= 1u << u;
    }
    return n;
}

void outputs_grid_sent(void)
{
    grid_due &= (uint8_t)~grid_put;
    grid_put = 0;
}

static int8_t unit_of(uint8_t pin)
{
    for (uint8_t u = 0; u < PWM_UNITS; u++)
        if (pgm_read_byte(&pwm_pin[u]) == pin)
            return (int8_t)u;
    return -1;
}

/* The period of timer 2 that runs at tick `now` (its number, wrapping). */
static inline __attribute__((always_inline)) uint16_t t2_period(uint32_t now)
{
    return (uint16_t)((now - period_origin[1]) >> period_log2[1]);
}

/* Timer-2 unit `u` gets compare value `value` now (interrupts off). */
static inline __attribute__((always_inline)) void ocr_written(uint8_t u, uint8_t value)
{
    uint16_t k = t2_period(ticks_now());
    if (ocr_period[u] != k)
        ocr_before[u] = ocr_last[u];  /* in effect from this period on */
    ocr_last[u] = value;
    ocr_period[u] = k;
}

/* The duty: `count` of 256 timer counts high (0: low, 256 or more: high). */
static void duty(uint8_t unit, uint32_t count)
{
    static const uint16_t ocr_reg[PWM_UNITS] PROGMEM = {
        (uint16_t)&OCR2B, (uint16_t)&OCR2A, (uint16_t)&OCR0B, (uint16_t)&OCR0A};
    static const uint16_t tccra_reg[PWM_UNITS] PROGMEM = {
        (uint16_t)&TCCR2A, (uint16_t)&TCCR2A, (uint16_t)&TCCR0A, (uint16_t)&TCCR0A};
    static const uint8_t com_bits[PWM_UNITS] PROGMEM = {
        _BV(COM2B1), _BV(COM2A1), _BV(COM0B1), _BV(COM0A1)};
    volatile uint8_t *ocr = (volatile uint8_t *)pgm_read_word(&ocr_reg[unit]);
    volatile uint8_t *tccra = (volatile uint8_t *)pgm_read_word(&tccra_reg[unit]);
    uint8_t com = pgm_read_byte(&com_bits[unit]);
    uint8_t pin = pgm_read_byte(&pwm_pin[unit]);
    uint8_t sreg = irq_save();
    if (count == 0) {
        *tccra &= (uint8_t)~com;  /* disconnected: the port holds it low */
        board_pin_write(pin, 0);
    } else {
        uint8_t value = count >= PWM_COUNTS ? 255 : (uint8_t)(count - 1);  /* high for count */
        if (unit <= PWM_OC2A)
            ocr_written(unit, value);
        *ocr = value;
        board_pin_write(pin, 0);
        *tccra |= com;  /* non-inverting: high from BOTTOM to the match */
    }
    irq_restore(sreg);
}

void outputs_pwm(const uint8_t *m)
{
    uint8_t pin = m[2];
    uint32_t clock_div = get_u32(m + 3), counts = get_u32(m + 7), count = get_u32(m + 11);
    int8_t unit = unit_of(pin);
    if (unit < 0 || counts != PWM_COUNTS) {
        counters.rejected++;  /* no PWM hardware there, or a TOP these timers cannot have */
        return;
    }
    if (unit <= PWM_OC2A) {
        static const uint16_t prescalers[7] PROGMEM = {1, 8, 32, 64, 128, 256, 1024};
        uint8_t cs = 0;
        for (uint8_t i = 0; i < 7; i++)
            if (pgm_read_word(&prescalers[i]) == clock_div)
                cs = i + 1;
        if (!cs) {
            counters.rejected++;
            return;
        }
        uint8_t sreg = irq_save();
        TCCR2A = (uint8_t)((TCCR2A & (_BV(COM2A1) | _BV(COM2A0) | _BV(COM2B1) | _BV(COM2B0)))
                           | _BV(WGM21) | _BV(WGM20));
        if ((TCCR2B & 7) != cs) {  /* (re)started: from BOTTOM now */
            TCNT2 = 0;
            TCCR2B = cs;
            period_origin[1] = ticks_now();
            uint8_t log2 = 8;
            for (uint16_t d = (uint16_t)clock_div; d > 1; d >>= 1)
                log2++;
            period_log2[1] = log2;
        }
        irq_restore(sreg);
    } else if (clock_div != 64) {
        counters.rejected++;  /* timer 0 keeps prescaler 64: it is the 1 ms tick too */
        return;
    }
    pwm_on |= 1u << unit;
    grid_due |= 1u << unit;  /* the host learns where the periods begin (PwmGrid) */
    duty((uint8_t)unit, count);
}

static void make(uint8_t flags, uint8_t pin, uint32_t value)
{
    if (flags & O_ANALOG) {
        int8_t unit = unit_of(pin);
        if (unit < 0 || !(pwm_on & (1u << unit))) {
            counters.rejected++;  /* no PWM set up on that pin */
            return;
        }
        duty((uint8_t)unit, value);
    } else if (board_pin_usable(pin)) {
        board_pin_write(pin, value ? 1 : 0);
    } else {
        counters.rejected++;
    }
}

void outputs_set(const uint8_t *m)
{
    uint8_t flags = m[1], pin = m[3];
    uint32_t value = get_u32(m + 4);
    if (!(flags & O_SYNCHRONIZED)) {
        make(flags, pin, value);
        return;
    }
    if (device_locked || waiting_count == SYNC_CHANGES) {
        counters.rejected++;
        return;
    }
    waiting[waiting_count].flags = flags;
    waiting[waiting_count].pin = pin;
    waiting[waiting_count].value = value > 0xFFFF ? 0xFFFF : (uint16_t)value;
    waiting_count++;
    outputs_poll();
}

void outputs_cancel(void)
{
    waiting_count = 0;
    timed_count = 0;  /* (one byte: the interrupts see it at once) */
}

static inline __attribute__((always_inline)) void timer2_timed(void);
/* timer2_timed from the main loop, interrupts off: its registers are saved in a frame
 * of its own, which no interrupt can stack on (the stack is short) */
static __attribute__((noinline)) void timer2_now(void);

/* The session's last timed change (OutputAt or OutputNext): an OutputNext is the next
 * change of the same output, `after` ticks after it.  NEXT_NONE: none yet. */
#define NEXT_NONE 0xFF
static uint32_t next_at;
static uint8_t next_flags = NEXT_NONE, next_pin;

static void timed_add(uint8_t flags, uint8_t pin, uint32_t value, uint32_t at);

void outputs_session(void)
{
    next_flags = NEXT_NONE;
}

void outputs_at(const uint8_t *m)
{
    uint8_t flags = m[1];
    if (flags & T_CANCEL) {
        outputs_cancel();
        return;
    }
    next_flags = flags;
    next_pin = m[3];
    next_at = get_u32(m + 8);
    timed_add(flags, next_pin, get_u32(m + 4), next_at);
}

void outputs_next(const uint8_t *m)
{
    if (next_flags == NEXT_NONE) {
        counters.rejected++;  /* no timed change in this session to count from */
        return;
    }
    next_at += get_u16(m + 3);
    timed_add(next_flags, next_pin, get_u16(m + 1), next_at);
}

static void timed_add(uint8_t flags, uint8_t pin, uint32_t value, uint32_t at)
{
    uint8_t unit = UNIT_DIGITAL;
    if (flags & O_ANALOG) {
        int8_t u = unit_of(pin);
        if (u < 0 || !(pwm_on & (1u << u))) {
            counters.rejected++;  /* no PWM set up on that pin */
            return;
        }
        unit = (uint8_t)u;
        value = value == 0 ? VALUE_OFF : value >= PWM_COUNTS ? 255 : value - 1;
    } else if (board_pin_usable(pin)) {
        value = value ? 1 : 0;
    } else {
        counters.rejected++;
        return;
    }
    uint8_t sreg = irq_save();
    if (timed_count == TIMED_SLOTS) {
        counters.rejected++;
    } else {
        uint8_t i = (uint8_t)((timed_first + timed_count) % TIMED_SLOTS);
        timed[i].at = at;
        timed[i].value = (uint8_t)value;
        timed[i].unit = unit;
        timed[i].pin = pin;
        timed_count++;
        /* one due in the running period is written now: the overflow that would write
         * it is past (its flag may be cleared already, by the interrupt for an earlier
         * change), and the next one would make it show a period late */
        if (unit <= PWM_OC2A)
            timer2_now();
        if (timed_count)
            TIMSK2 |= _BV(TOIE2);
    }
    irq_restore(sreg);
}

/* A PWM duty is double-buffered: written during a period it shows from the next one.
 * So a change at tick `at` is written in the period that contains `at` (or earlier in
 * the same period) and shows from the first period that begins after `at`, as a
 * compare would make it.  A change to 0 disconnects the pin, which is at once: on
 * timer 2 it waits until the running period's compare match has pulled the pin low
 * (its compare interrupt).  Timer 2's changes are made in its interrupts (kept small:
 * the stack is short); timer 0's and the digital ones by the main loop. */
static inline __attribute__((always_inline)) void timer2_timed(void)
{
    while (timed_count) {
        uint8_t i = timed_first;
        uint8_t u = timed[i].unit;
        if (u > PWM_OC2A)
            return;  /* the main loop's */
        uint32_t now = ticks_now();
        uint32_t rel = now - period_origin[1];
        uint32_t period = 1UL << period_log2[1];
        uint32_t pos = rel & (period - 1);
        if ((int32_t)(timed[i].at - (now - pos + period)) >= 0)
            return;  /* it belongs to a later period */
        uint8_t value = timed[i].value;
        uint8_t com = u ? _BV(COM2A1) : _BV(COM2B1);
        if (value == VALUE_OFF) {
            if (TCCR2A & com) {
                uint8_t ocr = ocr_period[u] == t2_period(now) ? ocr_before[u] : ocr_last[u];
                uint32_t match = ((uint32_t)ocr + 1) << (period_log2[1] - 8);
                if (pos < match) {  /* the pin is high until the match: wait for it */
                    TIFR2 = u ? _BV(OCF2A) : _BV(OCF2B);
                    TIMSK2 |= u ? _BV(OCIE2A) : _BV(OCIE2B);
                    if (((ticks_now() - period_origin[1]) & (period - 1)) < match)
                        return;
                }
                TCCR2A &= (uint8_t)~com;
            }
            if (u)
                PORTB &= (uint8_t)~_BV(3);  /* pin 11 */
            else
                PORTD &= (uint8_t)~_BV(3);  /* pin 3 */
        } else {
            ocr_written(u, value);
            if (u)
                OCR2A = value;
            else
                OCR2B = value;
            TCCR2A |= com;  /* (disconnected, the flip-flop is low: the pin from BOTTOM) */
        }
        timed_first = (uint8_t)((i + 1) % TIMED_SLOTS);
        timed_count--;
    }
}

static void timer2_now(void)
{
    timer2_timed();
}

ISR(TIMER2_OVF_vect)
{
    timer2_timed();
    if (!timed_count)
        TIMSK2 &= (uint8_t)~_BV(TOIE2);
}

ISR(TIMER2_COMPA_vect)
{
    TIMSK2 &= (uint8_t)~(_BV(OCIE2A) | _BV(OCIE2B));
    timer2_timed();
    if (!timed_count)
        TIMSK2 &= (uint8_t)~_BV(TOIE2);
}

ISR(TIMER2_COMPB_vect, ISR_ALIASOF(TIMER2_COMPA_vect));

/* The main loop's timed changes: digital ones at their tick, timer 0's in the period
 * that contains their tick (a change to 0 at once). */
static void timed_poll(void)
{
    for (;;) {
        uint8_t sreg = irq_save();
        uint8_t i = timed_first;
        if (!timed_count || timed[i].unit <= PWM_OC2A) {
            irq_restore(sreg);
            return;
        }
        uint32_t now = ticks_now();
        uint32_t due = now + 1;  /* digital: at its tick */
        if (timed[i].unit != UNIT_DIGITAL) {
            uint32_t period = 1UL << period_log2[0];
            due = now - ((now - period_origin[0]) & (period - 1)) + period;
        }
        if ((int32_t)(timed[i].at - due) >= 0) {
            irq_restore(sreg);
            return;
        }
        uint8_t unit = timed[i].unit, value = timed[i].value, pin = timed[i].pin;
        timed_first = (uint8_t)((i + 1) % TIMED_SLOTS);
        timed_count--;
        irq_restore(sreg);
        if (unit == UNIT_DIGITAL)
            board_pin_write(pin, value);
        else
            duty(unit, value == VALUE_OFF ? 0 : (uint32_t)value + 1);
    }
}

void outputs_poll(void)
{
    timed_poll();
    if (!waiting_count)
        return;
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        struct stepq *q = &stepq[ch];
        if (devq[ch].configured && (q->state || q->rp != q->wp))
            return;  /* motion commanded before the changes is not done */
    }
    for (uint8_t i = 0; i < waiting_count; i++)
        make(waiting[i].flags, waiting[i].pin, waiting[i].value);
    waiting_count = 0;
}
